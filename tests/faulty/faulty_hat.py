"""A faulty Build HAT for ``cmd:`` targets: ``buildhat-emulator --stdio`` behind a link fault.

    cmd:python tests/faulty/faulty_hat.py KIND [--after N] [--flood-seconds S] [--garbage-mb M]
        [--on PREFIX] [--log FILE] [-- emulator options...]

KIND (link_faults.py), or several separated by commas, each firing ``--gap`` host lines after the
one before it has done its work: ``drop`` / ``corrupt`` one line ending once; ``reboot`` once (the
emulator is restarted and prints its start-up banner again); go ``silent``; ``deaf`` (stop
reading stdin; the stdin pipe is shrunk to one page, as small as a UART's buffers, so the
host feels it within seconds); ``flood`` 3,000 junk lines/s (for ``--flood-seconds`` or
``--flood-lines``, default forever); ``garbage`` (``--garbage-mb`` MiB of binary noise, then
normal again); ``exit`` mid-run. Each fires once the host has sent N lines (default 40).
"""
from __future__ import annotations

import argparse
import fcntl
import os
import select
import subprocess
import sys
import time
from typing import List

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from link_faults import KINDS, LinkFault  # noqa: E402  (a script beside its module)

F_SETPIPE_SZ = 1031          # Linux fcntl: set a pipe's capacity
FLOOD_PER_S = 3000


def _emulator(args: list) -> subprocess.Popen:
    exe = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
    return subprocess.Popen([exe, "--stdio", *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE)


def _write(data: bytes) -> None:
    view = memoryview(data)
    while view:
        n = os.write(1, view)
        view = view[n:]


def _note(path, text: str) -> None:
    print(f"faulty_hat: {text}", file=sys.stderr, flush=True)
    if path:
        with open(path, "a", encoding="utf-8") as f:
            f.write(text + "\n")


def _kinds(text: str) -> List[str]:
    kinds = text.split(",")
    for kind in kinds:
        if kind not in KINDS:
            raise argparse.ArgumentTypeError(f"unknown fault {kind!r} (one of {', '.join(KINDS)})")
    return kinds


def main(argv: list) -> int:
    parser = argparse.ArgumentParser(prog="faulty_hat.py")
    parser.add_argument("kind", type=_kinds, help="a fault, or several in turn: drop,reboot,...")
    parser.add_argument("--after", type=int, default=40, help="host lines before the fault fires")
    parser.add_argument("--gap", type=int, default=40, help="host lines between one fault's end and the next")
    parser.add_argument("--flood-seconds", type=float, default=0.0, help="flood duration (0: forever)")
    parser.add_argument("--flood-lines", type=int, default=0, help="flood this many lines (0: no limit)")
    parser.add_argument("--garbage-mb", type=float, default=2.0)
    parser.add_argument("--on", default=None, help="fire at the first host line (after --after) starting so")
    parser.add_argument("--log", default=None, help="append a line here when the fault fires (for tests)")
    cut = argv.index("--") if "--" in argv else len(argv)
    opts = parser.parse_args(argv[:cut])
    opts.emulator = argv[cut + 1:]       # buildhat-emulator options, after --
    on = opts.on.encode() if opts.on else None
    kinds = list(opts.kind)
    fault = LinkFault(kinds.pop(0), opts.after, on=on)
    child = _emulator(opts.emulator)
    stdin = 0
    if "deaf" in opts.kind:
        try:
            fcntl.fcntl(stdin, F_SETPIPE_SZ, 4096)
        except OSError:
            pass   # not a pipe (a terminal): the fault still stops reading
    flood_from, flooded = 0.0, 0
    try:
        while True:
            if fault.done and kinds:
                fault = LinkFault(kinds.pop(0), opts.gap, on=on)
            assert child.stdout is not None     # each child has stdout=PIPE (a reboot starts a new one)
            reading = [child.stdout] + ([] if fault.fired and fault.kind == "deaf" else [stdin])
            flooding = fault.fired and not fault.done and fault.kind == "flood"
            ready, _, _ = select.select(reading, [], [], 0.001 if flooding else 0.5)
            if flooding:
                due = int((time.monotonic() - flood_from) * FLOOD_PER_S) - flooded
                if opts.flood_lines:
                    due = min(due, opts.flood_lines - flooded)
                if due > 0:
                    _write(fault.flood_lines(due, flooded))
                    flooded += due
                if (opts.flood_seconds and time.monotonic() - flood_from >= opts.flood_seconds) or \
                        (opts.flood_lines and flooded >= opts.flood_lines):
                    fault.done = True
                    _note(opts.log, f"flood ended after {flooded} lines")
            if child.stdout in ready:
                data = os.read(child.stdout.fileno(), 65536)
                if not data:
                    return child.wait()
                was_done = fault.done
                out = fault.output(data)
                if fault.done and not was_done:
                    _note(opts.log, f"{fault.kind}: output {data[:80]!r} went out as {out[:80]!r}")
                if out:
                    _write(out)
            if stdin in ready:
                data = os.read(stdin, 65536)
                if not data:
                    child.stdin.close()
                    return child.wait()
                fired = fault.host(data)
                if fired:
                    _note(opts.log, f"{fault.kind} fired after {fault.host_lines} host lines; "
                                    f"the last: {data[-60:]!r}")
                if fault.fired and fault.kind == "silent":
                    continue       # swallowed: a hung HAT
                child.stdin.write(data)
                child.stdin.flush()
                if not fired:
                    continue
                if fault.kind == "exit":
                    return 1
                if fault.kind == "flood":
                    flood_from, flooded = time.monotonic(), 0
                if fault.kind == "garbage":
                    left = int(opts.garbage_mb * 1024 * 1024)
                    while left > 0:
                        chunk = min(left, 65536)
                        _write(fault.garbage(chunk))
                        left -= chunk
                    fault.done = True
                if fault.kind == "reboot":
                    # Power-cycled: the old firmware is gone, the new one prints its banner.
                    child.kill()
                    child.wait()
                    child = _emulator([a for a in opts.emulator if a != "--booted"])
                    fault.done = True
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
