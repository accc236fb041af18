"""A planted fault as a byte proxy in front of ``buildhat-emulator --stdio``, for ``cmd:`` targets:

    cmd:python tests/planted/proxy.py wrong [emulator options...]

Host bytes go to the emulator and its output comes back through the same :class:`FaultFilter`
as the in-process wrappers (faults.py), so a finding's script can be replayed with
``buildhat-conformance script --target cmd:...`` and shows the same fault.
"""
from __future__ import annotations

import io
import os
import select
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from faults import FaultFilter  # noqa: E402  (a script beside its module, not a package)


def main(argv: list) -> int:
    if not argv:
        print("usage: proxy.py hang|wrong|drop [buildhat-emulator options]", file=sys.stderr)
        return 2
    fault = FaultFilter(argv[0])
    exe = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
    child = subprocess.Popen([exe, "--stdio", *argv[1:]], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    buffered = sys.stdin.buffer
    assert isinstance(buffered, io.BufferedReader) and child.stdout is not None
    host_in, host_out = buffered.raw, sys.stdout.buffer    # unbuffered: select() sees what waits
    wrong_next = False
    try:
        while True:
            ready, _, _ = select.select([host_in, child.stdout], [], [])
            if child.stdout in ready:
                data = os.read(child.stdout.fileno(), 65536)
                if not data:
                    return child.wait()
                out = fault.output(data, wrong_line=wrong_next and b"\r\n" in data)
                if wrong_next and b"\r\n" in data:
                    wrong_next = False
                if out:
                    host_out.write(out)
                    host_out.flush()
            if host_in in ready:
                data = os.read(host_in.fileno(), 65536)
                if not data:
                    child.stdin.close()
                    return child.wait()
                for chunk in fault.host_lines(data):
                    if fault.hung:
                        break
                    fire = fault.triggered(chunk)
                    child.stdin.write(chunk)
                    child.stdin.flush()
                    if fire and fault.kind == "hang":
                        fault.hung = True
                    elif fire:
                        # The next CRLF the emulator sends answers this line: an Error follows it.
                        wrong_next = True
    finally:
        if child.poll() is None:
            child.terminate()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
