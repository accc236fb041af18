"""A deliberately broken Build HAT: the reference emulator with ONE behaviour perturbed.

Used as ``BUILDHAT_EMULATOR="python mutant_emulator.py MUTATION"``, so the harness's
``emulator:`` target starts it like the real ``buildhat-emulator --pty --control ...``: it
starts the real emulator with the same arguments, makes a pty of its own, prints that path,
and relays bytes, changing them in the one way MUTATION names. The control channel is the
real emulator's, untouched, so world actions still work. The suite must notice each mutation
in the tests for that behaviour and only there (tests/test_conformance_mutants.py).
"""
from __future__ import annotations

import os
import re
import select
import signal
import subprocess
import sys
import time
import tty
from typing import Callable, Dict, Tuple

from buildhat_conformance.protocol.profiles import get_profile


def _vin_plus_one(line: bytes) -> bytes:
    m = re.fullmatch(rb"([0-9]+)\.([0-9]{2}) V", line)
    if not m:
        return line
    k = int(m.group(1)) * 100 + int(m.group(2)) + 1
    return f"{k // 100}.{k % 100:02d} V".encode()


def _unknown_version(line: bytes) -> bytes:
    # A release no profile knows, later than every known one: judged as the nearest earlier.
    if line.startswith(b"Firmware version: "):
        return b"Firmware version: 1740000000 2025-02-20T10:00:00+00:00"
    return line


def _no_done(line: bytes):
    return None if re.fullmatch(rb"P[0-3]: (pulse|ramp) done", line) else line


class _FirstFaultOnly:
    """'Port power fault' printed once, not repeated while the fault lasts."""

    def __init__(self) -> None:
        self.seen = False

    def __call__(self, line: bytes):
        if line != b"Port power fault":
            return line
        if self.seen:
            return None
        self.seen = True
        return line


def _no_error(line: bytes):
    return None if line == b"Error" else line


def _symbol_space_dropped(line: bytes) -> bytes:
    return line[:-1] if re.fullmatch(rb"  M[0-9]+ .+ SI = ", line) else line


def _pid_sign_flipped(line: bytes) -> bytes:
    m = re.fullmatch(rb"(P[0-3]: pv=.* cv=)(-?)(.*)", line)
    if not m:
        return line
    return m.group(1) + (b"" if m.group(2) else b"-") + m.group(3)


# Output mutations work on complete lines (None drops the line).
LINE_MUTATIONS: Dict[str, Callable[[bytes], object]] = {
    "vin-off-by-one": _vin_plus_one,
    "error-swallowed": _no_error,
    "list-symbol-space-dropped": _symbol_space_dropped,
    "pid-output-sign-flipped": _pid_sign_flipped,
    "done-dropped": _no_done,
    "port-fault-not-repeated": _FirstFaultOnly(),
    "none": lambda line: line,                 # a faithful relay (for the kill test)
    "unknown-version": _unknown_version,       # not a fault: a newer release (profile fallback)
}


def _last_match_rewriter(table: Tuple[str, ...]) -> Callable[[bytes], bytes]:
    """Input mutation: an ambiguous prefix typed as a command means the LAST command it
    prefixes (the table order reversed), by spelling that command out in full."""
    def first_word(segment: str) -> str:
        words = segment.split(" ")
        for i, w in enumerate(words):
            if w:
                names = [c for c in table if c.startswith(w)]
                if len(names) > 1 and w not in table:
                    words[i] = names[-1]
                break
        return " ".join(words)

    def rewrite(line: bytes) -> bytes:
        text = line.decode("latin-1")
        return ";".join(first_word(seg) for seg in text.split(";")).encode("latin-1")
    return rewrite


def main(argv: list) -> int:
    mutation, args = argv[0], argv[1:]
    firmware = args[args.index("--firmware") + 1] if "--firmware" in args else None
    table = get_profile(firmware).commands
    real = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
    child = subprocess.Popen([real] + args, stdout=subprocess.PIPE, stdin=subprocess.DEVNULL)
    signal.signal(signal.SIGTERM, lambda *_: (child.terminate(), sys.exit(0)))
    if os.environ.get("MUTANT_PIDFILE"):       # so a test can kill this "HAT" mid-run
        with open(os.environ["MUTANT_PIDFILE"], "w") as fh:
            fh.write(str(os.getpid()))
    real_path = child.stdout.readline().decode().strip()
    hat = os.open(real_path, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(hat)
    master, slave = os.openpty()
    tty.setraw(slave)
    print(os.ttyname(slave), flush=True)
    line_mutation = LINE_MUTATIONS.get(mutation)
    rewrite = _last_match_rewriter(table) if mutation == "prefix-last-match" else None
    out_buf, in_buf = b"", b""
    out_since = time.monotonic()
    while child.poll() is None:
        ready, _, _ = select.select([master, hat], [], [], 0.005)
        if hat in ready:
            data = os.read(hat, 65536)
            if not out_buf:
                out_since = time.monotonic()
            out_buf += data
        if master in ready:
            try:
                data = os.read(master, 65536)
            except OSError:
                data = b""
            if mutation == "lf-ignored":
                data = data.replace(b"\n", b"")
            if rewrite is None:
                os.write(hat, data)
            else:
                in_buf += data
                while b"\r" in in_buf:
                    line, in_buf = in_buf.split(b"\r", 1)
                    os.write(hat, rewrite(line) + b"\r")
        # Complete lines go out (mutated); a partial one (a prompt) after 10 ms as it is.
        while b"\r\n" in out_buf:
            line, out_buf = out_buf.split(b"\r\n", 1)
            new = line_mutation(line) if line_mutation else line
            if new is not None:
                os.write(master, new + b"\r\n")
        if out_buf and time.monotonic() - out_since > 0.01:
            os.write(master, out_buf)
            out_buf = b""
    return child.returncode or 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
