"""A serial device that is not a Build HAT: a modem-like program answering every CR with
``ERROR`` (CRLF around it), for ``cmd:`` targets. A run must refuse it in one line (exit 3), never
report it as a Build HAT failing a clause (harness/hat_evidence.py).

    cmd:python tests/faulty/not_a_hat.py
"""
from __future__ import annotations

import os
import sys


def main() -> int:
    while True:
        data = os.read(0, 4096)
        if not data:
            return 0
        for _ in range(data.count(b"\r")):
            os.write(1, b"\r\nERROR\r\n")


if __name__ == "__main__":
    sys.exit(main())
