"""A faulty link between the host and a HAT in its bootloader, as a real program (a cmd: target).

    python load_faulty_link.py (--flip N | --stop N) [-- EMULATOR ARGS...]

Runs ``buildhat-emulator --stdio --bootloader`` (plus the arguments after ``--``) and copies
bytes both ways. Counting host bytes from the first STX (0x02, the start of an upload):
``--flip N`` inverts byte N once (the image arrives changed: the bootloader's checksum fails);
``--stop N`` drops every host byte from byte N on (the upload stalls: its data timeout fires).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading


def main() -> int:
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    p = argparse.ArgumentParser()
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--flip", type=int)
    mode.add_argument("--stop", type=int)
    args = p.parse_args(argv)
    emulator = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
    child = subprocess.Popen([emulator, "--stdio", "--bootloader", *extra], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, bufsize=0)
    assert child.stdin is not None and child.stdout is not None

    def hat_to_host() -> None:
        while True:
            data = os.read(child.stdout.fileno(), 4096)
            if not data:
                os._exit(0)
            os.write(1, data)

    threading.Thread(target=hat_to_host, daemon=True).start()
    counted = -1                 # bytes since the first STX; -1 until it is seen
    while True:
        data = os.read(0, 4096)
        if not data:
            break
        out = bytearray()
        for b in data:
            if counted < 0 and b == 0x02:
                counted = 0
            if counted >= 0:
                if args.stop is not None and counted >= args.stop:
                    counted += 1
                    continue
                if args.flip is not None and counted == args.flip:
                    b ^= 0xFF
                counted += 1
            out.append(b)
        if out:
            child.stdin.write(bytes(out))
    child.stdin.close()
    child.wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
