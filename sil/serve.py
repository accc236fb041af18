"""The real firmware in the loop at wall-clock pace, on a pty, TCP or stdio (``sil serve``).

The counterpart of ``buildhat-emulator --pty`` for a firmware built with the stand-in: the same
real-time loop, links and control channel (``emulator/runners``, ``serving/control_channel.py``), with
a :class:`~.hat.SilHat` where the emulator's model would be. Host libraries drive it as they
drive a HAT; the ``sil:...?speed=N`` target starts it. Options are the emulator's, so the
emulator target's process handling serves both: ``--pty | --tcp [HOST:]PORT | --stdio``,
``--speed N``, ``--device P=SPEC``, ``--booted``, ``--seed N``, ``--control PATH``,
``--firmware RELEASE`` (the release whose device-side timing the world uses).
A firmware that crashes or exits ends this program with status 3 and its report on stderr.

The host's bytes reach the firmware at the wire's pace (``SilHat.host_room``), so a host that writes faster
is pushed back as a serial port pushes it back; ``@firmware`` names the version the firmware reports and
``@lint`` is the emulator's host lint (``host_lint.py``), as ``buildhat-emulator`` answers them.
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
from typing import TYPE_CHECKING, Optional, Sequence

from ..plumbing.cli_options import OneLineParser
from ..serving.device_options import device_options
from .process import FirmwareDied

if TYPE_CHECKING:
    from .hat import SilHat
    from .host_lint import FirmwareLint

__all__ = ["main", "build_parser"]


def build_parser(prog: str = "buildhat-conformance sil serve") -> argparse.ArgumentParser:
    p = OneLineParser(prog=prog, description="Serve a firmware built for this host at wall-clock pace.")
    p.add_argument("program", metavar="TREE|PROGRAM",
                   help="a firmware tree (built on first use) or a built program")
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--pty", action="store_true", help="serve on a new pseudo-terminal (prints its path)")
    mode.add_argument("--tcp", metavar="[HOST:]PORT", help="serve on a TCP port (127.0.0.1 by default)")
    mode.add_argument("--stdio", action="store_true", help="serve on stdin/stdout")
    p.add_argument("--speed", type=float, default=1.0, metavar="N", help="N times real time (default 1)")
    p.add_argument("--device", action="append", default=[], metavar="P=SPEC", help="a device on port P")
    p.add_argument("--booted", action="store_true", help="start with the start-up done (devices established)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed for the device models")
    p.add_argument("--firmware", default=None, metavar="RELEASE",
                   help="release whose device timing the world uses")
    p.add_argument("--control", metavar="PATH|tcp:HOST:PORT",
                   help="serve the control channel (world actions)")
    p.add_argument("--sanitize", default="", metavar="LIST", help="with a tree: build with these sanitizers")
    p.add_argument("--link", metavar="PATH", help="with --pty: also make PATH a symlink to the pty")
    return p


def _hat(args: argparse.Namespace, parser: argparse.ArgumentParser) -> SilHat:
    from ..harness.targets.base import TargetError
    from .target import SilTarget, program_for
    try:
        program, _build = program_for(args.program, [s for s in args.sanitize.split(",") if s], False)
        devices = device_options(args.device, parser)
        target = SilTarget(program, f"sil:{program}", devices=dict(devices), seed=args.seed, boot=False,
                           firmware=args.firmware)
        # served for as long as the host likes: no event list, so memory stays flat
        return target.new_hat(target.firmware, target.devices, target.seed, record_events=False)
    except TargetError as exc:
        parser.error(str(exc))


def _lint(hat: SilHat, booted: bool) -> FirmwareLint:
    """The host lint, reading host lines as the release the firmware reports (sil/host_lint.py)."""
    from ..protocol.profiles import resolve_version
    from .host_lint import FirmwareLint
    words = hat.reported_version().split()
    release = resolve_version(int(words[0]))[0].name if words and words[0].isdigit() else None
    return FirmwareLint(profile_of=lambda: None, firmware=hat, release=release, booted=booted)


def main(argv: Optional[Sequence[str]] = None) -> int:
    from ..serving.control_channel import ENV_TOKEN, ControlHandler, ControlServer
    from ..serving.realtime.clock import RealTimeClock
    from ..serving.realtime.host_links import PtyLink, StdioLink, TcpLink
    from ..serving.realtime.loop import run_realtime

    parser = build_parser()
    args = parser.parse_args(argv)
    if args.speed <= 0:
        parser.error("--speed must be positive")
    hat = _hat(args, parser)
    link = control = lint = None
    signal.signal(signal.SIGTERM, lambda s, f: (_ for _ in ()).throw(SystemExit(128 + s)))
    try:
        if args.booted:
            hat.boot()
            hat.read()                       # printed to nobody: the host was not there yet
        lint = _lint(hat, args.booted)
        clock = RealTimeClock(args.speed)
        if args.control:
            control = ControlServer(args.control, ControlHandler(hat, clock, lint),
                                    token=os.environ.get(ENV_TOKEN) or None)
            print(f"buildhat-conformance sil serve: {control.environment()}", file=sys.stderr, flush=True)
        if args.pty:
            link = PtyLink(args.link)
            where = link.path
        elif args.tcp:
            link = TcpLink(args.tcp, paced=True)     # the wire's pace: a small window pushes back
            where = link.address
        else:
            link = StdioLink()
            where = "stdio"
        if not args.stdio:
            print(where, flush=True)
        return run_realtime(hat, link, clock, control, lint)
    except FirmwareDied as exc:
        print(f"buildhat-conformance sil serve: {exc.summary}", file=sys.stderr)
        if exc.report:
            print(exc.report, file=sys.stderr)
        return 3
    except RuntimeError as exc:           # the start-up never finished
        print(f"buildhat-conformance sil serve: {exc}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        return 130
    finally:
        if lint is not None and (lint.lines or not lint.clean):   # its report on stderr, as the emulator's
            lint.finish()
            print(lint.report(), file=sys.stderr, flush=True)
        if control is not None:
            control.close()
        if link is not None:
            link.close()
        hat.close()


if __name__ == "__main__":
    sys.exit(main())
