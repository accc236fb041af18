"""A Build HAT that answers wrongly but well: ``buildhat-emulator --stdio`` with one protocol
behaviour changed, for ``cmd:`` targets (issue 24). Its answers stay well-formed lines in time, so
a conformance run must report them as ``fail`` of the clause they break, never as target faults.

    cmd:python tests/faulty/wrong_hat.py KIND [-- emulator options...]

KIND:
- ``port-error``: ``port N`` with N above 3 prints ``Error`` instead of selecting port 3 (the
  document and FIRMWARE-FACTS §3 clamp it);
- ``first-command``: of a line of several commands separated by ``;`` only the first runs (the
  document's separator clause, SYN-SEMICOLON). Everything the host typed is still echoed.
- ``no-echo``: ``echo 1`` leaves echo off (CMD-ECHO): nothing is ever echoed, no prompt.
- ``version-error``: ``version`` (and the prefixes the firmware resolves to it) prints ``Error``
  (CMD-VERSION): the run cannot identify the release, but the CRLF and ``Error`` show a Build HAT.
- ``portless-prompt``: the prompt is ``P>`` instead of ``P<port>>`` (LINK-PROMPT; the firmware's
  decimal printer printing nothing does that, among other things). A rewrite of the output.

The change is made on the host's bytes on their way in: each rewrite keeps the line's length and
replaces bytes the firmware would have parsed with bytes that make it do the wrong thing. With echo
on, the emulator echoes the rewritten bytes; they are put back to what the host typed on the way
out, as a HAT with that behaviour would echo them.
"""
from __future__ import annotations

import os
import re
import select
import subprocess
import sys
from typing import Callable, Dict

#: `port` (or a prefix the firmware resolves to it) and a number above 3.
_PORT_ABOVE_3 = re.compile(rb"(?:^|(?<=[ ;]))(p|po|por|port)([ ;] *)([4-9]|[1-9][0-9]+)(?=[ ;]|$)")


def port_error(line: bytes) -> bytes:
    """``port 9`` -> ``port x`` (same length): the firmware prints Error and drops the rest."""
    return _PORT_ABOVE_3.sub(lambda m: m.group(1) + m.group(2) + b"x" * len(m.group(3)), line)


def first_command(line: bytes) -> bytes:
    """Everything from the first ``;`` after a command on: a NUL ends what the firmware parses
    (FACTS §1), and the other bytes are still stored and echoed as typed. A line that begins
    with separators keeps them (the first command comes after them)."""
    body = line.split(b"\x00", 1)[0]
    stripped = body.lstrip(b" ;")
    cut = stripped.find(b";")
    if cut < 0:
        return line
    at = len(body) - len(stripped) + cut
    return line[:at] + b"\x00" + line[at + 1:]


_ECHO_ON = re.compile(rb"(?:^|(?<=[ ;]))(e|ec|ech|echo)([ ;] *)([+-]?0*[1-9][0-9]*)(?=[ ;\x00]|$)")


def no_echo(line: bytes) -> bytes:
    """``echo 1`` -> ``echo 0`` (same length, every digit zeroed): echo never turns on."""
    return _ECHO_ON.sub(lambda m: m.group(1) + m.group(2) + re.sub(rb"[1-9]", b"0", m.group(3)), line)


_VERSION = re.compile(rb"(?:^|(?<=[ ;]))(ve|ver|vers|versi|versio|version)(?=[ ;]|$)")


def version_error(line: bytes) -> bytes:
    """``version`` -> ``xersion`` (same length): no command name matches, the firmware prints Error."""
    return _VERSION.sub(lambda m: b"x" + m.group(1)[1:], line)


REWRITES: Dict[str, Callable[[bytes], bytes]] = {"port-error": port_error, "first-command": first_command,
                                                 "no-echo": no_echo, "version-error": version_error,
                                                 "portless-prompt": lambda line: line}


class PortlessPrompt:
    """``P0>`` ... ``P3>`` -> ``P>`` in the output; a ``P`` or ``P<digit>`` at the end of a read
    waits for the next one (or a pause: ``flush``)."""

    def __init__(self) -> None:
        self.held = b""

    def output(self, data: bytes) -> bytes:
        out = re.sub(rb"P[0-3]>", b"P>", self.held + data)
        tail = re.search(rb"P[0-3]?$", out)
        self.held = out[tail.start():] if tail else b""
        return out[:tail.start()] if tail else out

    def flush(self) -> bytes:
        out, self.held = self.held, b""
        return out


OUTPUT_REWRITES = {"portless-prompt": PortlessPrompt}


class EchoRestorer:
    """Puts the host's own bytes back into the echo of a rewritten line. Output that may be the
    start of such an echo is held back until it is told apart (or output pauses: ``flush``)."""

    KEEP = 16          # rewritten lines remembered (with echo off their echo never comes)

    def __init__(self) -> None:
        self.subs: list = []        # (rewritten, original), oldest first
        self.held = b""

    def sent(self, rewritten: bytes, original: bytes) -> None:
        if rewritten != original:
            self.subs = (self.subs + [(rewritten, original)])[-self.KEEP:]

    def output(self, data: bytes) -> bytes:
        out = self.held + data
        for i, (rewritten, original) in enumerate(self.subs):
            at = out.find(rewritten)
            if at >= 0:
                out = out[:at] + original + out[at + len(rewritten):]
                del self.subs[i]
                break
        hold = 0
        for rewritten, _ in self.subs:
            for n in range(min(len(rewritten) - 1, len(out)), hold, -1):
                if out.endswith(rewritten[:n]):
                    hold = n
                    break
        self.held = out[len(out) - hold:] if hold else b""
        return out[:len(out) - hold]

    def flush(self) -> bytes:
        out, self.held = self.held, b""
        return out


def _write(data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(1, view):]


def main(argv: list) -> int:
    cut = argv.index("--") if "--" in argv else len(argv)
    if cut != 1 or argv[0] not in REWRITES:
        print(f"wrong_hat.py: usage: wrong_hat.py {{{','.join(REWRITES)}}} [-- emulator options]",
              file=sys.stderr)
        return 2
    rewrite = REWRITES[argv[0]]
    exe = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
    child = subprocess.Popen([exe, "--stdio", *argv[cut + 1:]], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    assert child.stdin is not None and child.stdout is not None
    pending = b""              # host bytes of a line not yet ended by CR
    echo = EchoRestorer()
    outer = OUTPUT_REWRITES.get(argv[0], EchoRestorer)()    # EchoRestorer with nothing to restore: as is
    try:
        while True:
            held = echo.held or outer.held
            ready, _, _ = select.select([child.stdout, 0], [], [], 0.05 if held else 0.5)
            if not ready and held:
                _write(outer.output(echo.flush()) + outer.flush())   # output paused: nothing more is coming
            if child.stdout in ready:
                data = os.read(child.stdout.fileno(), 65536)
                if not data:
                    _write(outer.output(echo.flush()) + outer.flush())
                    return child.wait()
                _write(outer.output(echo.output(data)))
            if 0 in ready:
                data = os.read(0, 65536)
                if not data:
                    child.stdin.close()
                    return child.wait()
                # Whole lines are rewritten; the bytes of a line still being typed wait for its CR
                # (the firmware parses a line only at its CR, so holding them back changes nothing
                # but the echo's timing).
                pending += data
                *lines, pending = pending.split(b"\r")
                if lines:
                    rewritten = [rewrite(line) for line in lines]
                    for new, old in zip(rewritten, lines):
                        echo.sent(new, old)
                    child.stdin.write(b"".join(line + b"\r" for line in rewritten))
                    child.stdin.flush()
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
