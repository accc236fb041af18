"""A deliberately broken Build HAT: the reference emulator with ONE behaviour perturbed.

Used as ``BUILDHAT_EMULATOR="python mutant_emulator.py MUTATION"``, so the harness's
``emulator:`` target starts it like the real ``buildhat-emulator --pty --control ...``: it
starts the real emulator with the same arguments, makes a pty of its own, prints that path,
and relays bytes, changing them in the one way MUTATION names. The control channel is the
real emulator's, untouched, so world actions still work. The suite must notice each mutation
in the tests for that behaviour and only there (tests/end_to_end/test_conformance_mutants.py).
"""
from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
import tty

from line_mutations import Mutation  # beside this file (run as a script)


def main(argv: list) -> int:
    mutation, args = argv[0], argv[1:]
    firmware = args[args.index("--firmware") + 1] if "--firmware" in args else None
    mutate = Mutation(mutation, firmware)
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
    out_buf = b""
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
            os.write(hat, mutate.host(data))
        # Complete lines go out (mutated); a partial one (a prompt) after 10 ms as it is.
        while b"\r\n" in out_buf:
            line, out_buf = out_buf.split(b"\r\n", 1)
            new = mutate.line(line)
            if new is not None:
                os.write(master, new + b"\r\n")
        if out_buf and time.monotonic() - out_since > 0.01:
            os.write(master, out_buf)
            out_buf = b""
    return child.returncode or 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
