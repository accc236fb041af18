"""``buildhat-emulator``: the reference Build HAT emulator as a process.

Exactly one mode: ``--pty`` (prints the slave path as the first stdout line), ``--tcp
[HOST:]PORT`` (prints HOST:PORT), ``--stdio``, or ``--script FILE`` (virtual time; transcript
JSONL on stdout).
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import textwrap
from typing import Dict, Optional, Sequence

from ..serving.device_options import device_options

__all__ = ["main", "build_parser"]

# --booted --baud: at most this long (virtual ms) for the start-up's output to leave the TX ring (8 KB at
# 9600 baud takes about 8.5 s).
BOOT_DRAIN_LIMIT_MS = 20000
# --pty and --tcp are where host libraries meet the emulator: a HAT's wire unless told otherwise.
WIRE_BAUD = 115200

CONTROL_HELP = """\
control channel (--control PATH for a Unix socket, or --control tcp:HOST:PORT):
  at start stderr shows "buildhat-emulator: BUILDHAT_EMULATOR_CONTROL=<address>" (on TCP also
  "BUILDHAT_EMULATOR_TOKEN=<token>": send "@auth TOKEN" first; set that variable beforehand to choose
  the token). One request per line, one reply per line ("ok", "ok <value>" or "error <message>").
  World actions as in a scenario script: @plug P SPEC, @unplug P, @data P M HH.. | auto,
  @motorfault 1 P [F4D F4E F4F] | 0 [P], @portfault 1|0 | 1 MS (MS ms of HAT time), @button P 0|1, @adc RAW,
  @rate P MS, @hold P 0|1, @pos P DEG.  Also: @reset, @reset bootloader, @time (virtual ms),
  @firmware (version string), @speed [N] (get/set), @lint (host-traffic lint, JSON),
  @settled (1 once the start-up is done and the devices are up),
  @gpio reset|boot0 0|1|z (the HAT's RESET/BOOT0 lines; GPIOZERO_PIN_FACTORY=buildhat_emulator).
device SPEC: an active type id in hex (0x30), "passive N", or "none".
default layout: P0 0x30, P1 0x40, P2 passive 8, P3 none.
"""


def build_parser() -> argparse.ArgumentParser:
    # The options buildhat-conformance shares (docs/USING.md, "Options"): one line per mistake, no
    # abbreviations (--version is not --version-string), -o/--output for the file it writes.
    from ..plumbing.cli_exits import exit_status_help
    from ..plumbing.cli_options import RELEASE_HELP, SPEED_HELP, OneLineParser, add_hidden_alias
    from ..plumbing.package_version import __version__

    p = OneLineParser(
        prog="buildhat-emulator", description="Reference emulator of the Raspberry Pi Build HAT "
        "firmware (releases R1..R7) on its serial command port.",
        epilog=CONTROL_HELP + "\n" + textwrap.fill(exit_status_help("buildhat-emulator"), 104),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--pty", action="store_true", help="serve on a new pseudo-terminal (raw mode)")
    mode.add_argument("--tcp", metavar="[HOST:]PORT", help="serve on a TCP port (host 127.0.0.1 by default)")
    mode.add_argument("--stdio", action="store_true", help="serve on stdin/stdout")
    mode.add_argument("--script", metavar="FILE", help="run a scenario script in virtual time; "
                      "transcript JSONL on stdout")
    p.add_argument("--link", metavar="PATH", help="with --pty: also make PATH a symlink to the pty")
    p.add_argument("--firmware", default="latest", metavar="RELEASE",
                   help=f"the firmware release to run: {RELEASE_HELP} (default latest)")
    p.add_argument("--version-string", metavar="S", help="text printed after 'Firmware version: '")
    p.add_argument("--device", action="append", default=[], metavar="P=SPEC",
                   help="device on port P at power-on (repeatable); SPEC as in a script's @device")
    p.add_argument("--bootloader", action="store_true",
                   help="start in the bootloader (as after power-on)")
    p.add_argument("--bootloader-key", metavar="FILE",
                   help="PEM P-256 public key the bootloader verifies with")
    p.add_argument("--booted", action="store_true",
                   help="start powered up: start-up done and the devices established, run in virtual "
                        "time before the link opens (its output went to no host)")
    p.add_argument("--speed", type=float, default=1.0, metavar="N", help=f"{SPEED_HELP} (default 1)")
    p.add_argument("--baud", type=int, metavar="B",
                   help="pace the serial link both ways at B baud (B/10 bytes/s), as a HAT's wire; "
                        f"default {WIRE_BAUD} with --pty and --tcp, unpaced with --stdio and --script; "
                        "0: an unpaced link (every byte at once)")
    p.add_argument("--fast-setup", action="store_true",
                   help="devices send their set-up faster than a HAT's 2400 baud (a quicker start-up "
                        "and hot-plug for test suites; default: the real rate)")
    p.add_argument("--hang-after", type=int, metavar="N",
                   help="fault injection: the firmware hangs after the host's Nth line (once; reads and "
                        "prints nothing until a reset, @reset or the RESET line); also @hang on --control")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed for the device models' noise")
    p.add_argument("--strict-host", action="store_true",
                   help="exit with an error at the first host-lint finding")
    p.add_argument("--control", metavar="PATH|tcp:HOST:PORT", help="serve the control channel there "
                   "(a Unix socket is mode 0600; TCP is loopback only and asks for the per-run token)")
    p.add_argument("--allow-remote", action="store_true",
                   help="let the TCP control channel listen on a non-loopback address")
    p.add_argument("-o", "--output", dest="transcript", metavar="FILE",
                   help="write every byte both ways, device events and host-lint findings (as notes) "
                        "to FILE as a JSONL transcript (with --script: instead of stdout)")
    add_hidden_alias(p, "--transcript", dest="transcript")
    return p


def _check(args: argparse.Namespace, parser: argparse.ArgumentParser) -> None:
    from ..protocol.profiles import get_profile

    try:
        get_profile(args.firmware)
    except KeyError as exc:
        parser.error(str(exc.args[0]))
    if not args.speed > 0:
        parser.error(f"--speed must be positive, got {args.speed:g}")
    if args.baud is not None and args.baud < 0:
        parser.error(f"--baud must be positive (or 0: unpaced), got {args.baud}")
    if args.hang_after is not None and args.hang_after < 1:
        parser.error(f"--hang-after must be at least 1 line, got {args.hang_after}")
    if args.hang_after is not None and args.script:
        parser.error("--hang-after is for the real-time modes (a script has no reset to end the hang)")
    if args.link and not args.pty:
        parser.error("--link needs --pty")
    if args.script and args.control:
        parser.error("--control is for the real-time modes; a script carries its own world actions")
    if args.script and args.bootloader:
        parser.error("--script starts from the firmware; --bootloader is for the real-time modes")
    if args.booted and (args.script or args.bootloader):
        parser.error("--booted starts the firmware of a real-time mode; not with "
                     + ("--script" if args.script else "--bootloader"))
    if args.allow_remote and not (args.control or "").startswith("tcp:"):
        parser.error("--allow-remote is for a TCP control channel (--control tcp:HOST:PORT)")
    if args.transcript and args.stdio and args.transcript == "-":
        parser.error("-o -: stdout is the serial link with --stdio; give a file")
    if args.tcp:
        from ..serving.realtime.host_links import parse_tcp_address
        try:
            parse_tcp_address(args.tcp)
        except ValueError as exc:
            parser.error(str(exc))
    if args.bootloader_key and not os.path.isfile(args.bootloader_key):
        parser.error(f"--bootloader-key {args.bootloader_key!r}: no such file")


def link_baud(args: argparse.Namespace) -> Optional[int]:
    """The wire's baud rate for this mode (None: unpaced): ``--baud``, else a HAT's 115200 on
    ``--pty`` and ``--tcp``; ``--baud 0`` is unpaced."""
    if args.baud is not None:
        return args.baud or None
    return WIRE_BAUD if (args.pty or args.tcp) else None


def _lint(args: argparse.Namespace):
    from ..serving.host_lint.lint import HostLint

    return HostLint(profile_of=lambda: None, strict=args.strict_host)


def _run_script(args: argparse.Namespace, devices: Dict[int, Optional[tuple]]) -> int:
    from ..plumbing.package_version import __version__
    from ..transcripts.script import ScriptError, load_script
    from .script_mode import ScriptRunError, run_script

    try:
        script = load_script(args.script)
    except OSError as exc:
        print(f"buildhat-emulator: cannot read {args.script}: {exc.strerror}", file=sys.stderr)
        return 2
    except ScriptError as exc:
        print(f"buildhat-emulator: {exc}", file=sys.stderr)
        return 2
    lint = _lint(args)
    try:
        out = open(args.transcript, "w", encoding="utf-8") if args.transcript else sys.stdout
    except OSError as exc:
        print(f"buildhat-emulator: cannot write {args.transcript}: {exc.strerror}", file=sys.stderr)
        return 2
    try:
        run_script(script, out, firmware=args.firmware, devices=devices,
                   version_string=args.version_string, seed=args.seed, baud=link_baud(args), lint=lint,
                   fast_setup=args.fast_setup,
                   tool_version=__version__, lint_notes=bool(args.transcript))
    except (ScriptRunError, RuntimeError) as exc:    # RuntimeError: the layout never came up
        print(f"buildhat-emulator: {exc}", file=sys.stderr)
        return 2
    finally:
        if out is not sys.stdout:
            out.close()
    _report(lint)
    if args.strict_host and lint.fatal_message():
        print(lint.fatal_message(), file=sys.stderr)
        return 3
    return 0


def _run_realtime(args: argparse.Namespace, devices: Dict[int, Optional[tuple]]) -> int:
    from ..plumbing.package_version import __version__
    from ..serving.control_channel import ENV_TOKEN, ControlHandler, ControlServer
    from ..serving.realtime.clock import RealTimeClock
    from ..serving.realtime.host_links import PtyLink, StdioLink, TcpLink
    from ..serving.realtime.loop import run_realtime
    from ..serving.realtime.recording import LinkRecorder
    from .api import Emulator

    lint = _lint(args)
    baud = link_baud(args)
    link = control = recorder = None
    status: Optional[int] = None
    try:
        emulator = Emulator(firmware=args.firmware, devices=devices, version_string=args.version_string,
                            bootloader=args.bootloader, seed=args.seed, baud=baud,
                            bootloader_key=args.bootloader_key, record_events=False,
                            hang_after=args.hang_after, fast_setup=args.fast_setup)
        if args.booted:
            # A HAT powered up before the host opened the port: what it printed then reached
            # nobody. Seconds of device set-up at real time become milliseconds of CPU.
            try:
                emulator.boot()
            except RuntimeError as exc:         # the layout never came up
                print(f"buildhat-emulator: --booted: {exc}", file=sys.stderr)
                return 2
            # With --baud the last device dumps still wait in the TX ring for the wire: they too went
            # out to nobody (a host that connects then must not read seconds-old start-up lines).
            for _ in range(BOOT_DRAIN_LIMIT_MS):
                if not emulator.uart.tx_pending():
                    break
                emulator.step()
            emulator.read()
        lint.follow(emulator)
        clock = RealTimeClock(args.speed)
        if args.control:
            # Before the link: the first stdout line (the pty path) means everything is listening.
            control = ControlServer(args.control, ControlHandler(emulator, clock, lint),
                                    token=os.environ.get(ENV_TOKEN) or None, allow_remote=args.allow_remote)
            print(f"buildhat-emulator: {control.environment()}", file=sys.stderr, flush=True)
        if args.pty:
            link = PtyLink(args.link)
            where = link.path
        elif args.tcp:
            link = TcpLink(args.tcp, paced=baud is not None)
            where = link.address
        else:
            link = StdioLink()
            where = "stdio"
        if args.transcript:
            try:
                recorder = LinkRecorder(args.transcript, emulator, {
                    "target": "emulator", "tool": "buildhat-emulator", "version": __version__,
                    "link": where, "profile": emulator.profile.name, "baud": baud,
                    "booted": bool(args.booted)}).attach(lint)
            except OSError as exc:
                print(f"buildhat-emulator: cannot write {args.transcript}: {exc.strerror}", file=sys.stderr)
                return 2
        if not args.stdio:
            print(where, flush=True)
        status = run_realtime(emulator, link, clock, control, lint, tap=recorder)
        return status
    except ValueError as exc:
        print(f"buildhat-emulator: {exc}", file=sys.stderr)
        status = 2
        return 2
    finally:
        if control is not None:
            control.close()
        if link is not None:
            link.close()
        _report(lint)
        if recorder is not None:
            lint.finish()       # an open overrun episode becomes a finding (a note) before the end event
            recorder.close(status)


def _report(lint) -> None:
    """The host-lint report on stderr at exit (stdout may be the data channel)."""
    if lint.lines or not lint.clean:
        lint.finish()
        print(lint.report(), file=sys.stderr, flush=True)


def _terminate(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)   # unwinds through the finally blocks: sockets and links cleaned up


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    _check(args, parser)
    devices = device_options(args.device, parser)
    previous = {sig: signal.signal(sig, _terminate) for sig in (signal.SIGTERM, signal.SIGHUP)}
    try:
        if args.script:
            return _run_script(args, devices)
        return _run_realtime(args, devices)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return 0
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


if __name__ == "__main__":
    sys.exit(main())
