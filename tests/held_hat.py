"""A HAT that answers only once the host has stopped talking: ``buildhat-emulator --stdio`` whose
output is held back until the host has sent nothing for QUIET seconds, for ``cmd:`` targets:

    cmd:python tests/held_hat.py QUIET [emulator options...]

A host that sends its lines back to back, without waiting for answers, has sent them all before the
first answer arrives, whatever the machine's load; a host that waits for an answer before its next
line cannot (the answer comes only after QUIET seconds of its silence). Tests use it to make "every
line was out before the first answer" a property of the host, not of timing luck.
"""
from __future__ import annotations

import io
import os
import select
import subprocess
import sys
import time


def main(argv: list) -> int:
    try:
        quiet = float(argv[0])
    except (IndexError, ValueError):
        print("usage: held_hat.py QUIET_SECONDS [buildhat-emulator options]", file=sys.stderr)
        return 2
    exe = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
    child = subprocess.Popen([exe, "--stdio", *argv[1:]], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    assert child.stdin is not None and child.stdout is not None
    buffered = sys.stdin.buffer
    assert isinstance(buffered, io.BufferedReader)
    host_in = buffered.raw              # unbuffered: select() sees what is really waiting
    held = b""
    last_host = time.monotonic()
    try:
        while True:
            wait = max(0.0, last_host + quiet - time.monotonic()) if held else None
            ready, _, _ = select.select([host_in, child.stdout], [], [], wait)
            if child.stdout in ready:
                data = os.read(child.stdout.fileno(), 65536)
                if not data:
                    return child.wait()
                held += data
            if host_in in ready:
                data = os.read(host_in.fileno(), 65536)
                if not data:
                    return 0
                last_host = time.monotonic()
                child.stdin.write(data)
                child.stdin.flush()
            if held and time.monotonic() - last_host >= quiet:
                sys.stdout.buffer.write(held)
                sys.stdout.buffer.flush()
                held = b""
    finally:
        child.kill()
        child.wait()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
