"""What a host sees when it writes faster than the wire: the user's ``buildhat-emulator --pty --baud 115200
--booted`` as the HAT, a pyserial port in this process as the host (issue 14).

A 51,000-byte write needs 4.43 s on a 115200-baud wire (10 bits a byte). The emulator reads no more host
bytes than the wire carries, so the HAT's answer to the line after the upload comes no sooner than that;
the host's ``write()`` itself returns earlier, by what the link holds when its last bytes go in: a real
UART's 4 KB transmit buffer (about 4.07 s), a pty's kernel buffers (13-20 KB, a figure that depends on
how the upload's size falls against the pty's refills; docs/HOST-LIBRARIES.md). ``flush()`` (tcdrain)
waits for nothing on a pty. The small-command figure is a ``version`` round trip on the same paced link.
"""
from __future__ import annotations

import statistics
import subprocess
import time
from typing import Any, Dict

from .firmware_load import installed_tool

__all__ = ["host_write", "PAYLOAD", "BAUD"]

PAYLOAD = 51_000             # issue 14's upload: 4.43 s at 115200 baud
BAUD = 115200
UART_XMIT = 4096             # a real serial port's kernel transmit buffer (UART_XMIT_SIZE, one 4 KB page)
ROUND_TRIPS = 15
_ANSWER = b"Firmware version: "
_TIMEOUT_S = 60.0


def _answer(port: Any, since: float) -> float:
    """Seconds from ``since`` until a whole ``Firmware version:`` line has arrived."""
    got = b""
    while time.monotonic() - since < _TIMEOUT_S:
        got += port.read(max(1, port.in_waiting))
        at = got.find(_ANSWER)
        if at >= 0 and got.find(b"\n", at) >= 0:
            return time.monotonic() - since
    raise RuntimeError(f"no version answer within {_TIMEOUT_S:g} s")


def host_write(payload: int = PAYLOAD, baud: int = BAUD) -> Dict[str, Any]:
    """One emulator, ``ROUND_TRIPS`` version round trips, then a ``payload``-byte write and the answer
    to the line after it."""
    import serial

    rate = baud / 10.0
    emu = subprocess.Popen([installed_tool("buildhat-emulator"), "--pty", "--baud", str(baud), "--booted"],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                           start_new_session=True)
    try:
        assert emu.stdout is not None
        path = emu.stdout.readline().strip()
        if not path:
            raise RuntimeError(f"buildhat-emulator exited {emu.wait(timeout=10)} before serving a pty")
        with serial.Serial(path, baud, timeout=0.05) as port:
            rtts = []
            for _ in range(ROUND_TRIPS):
                began = time.monotonic()
                port.write(b"version\r")
                rtts.append(_answer(port, began) * 1000.0)
            # No CR in the upload: the firmware keeps a line's first 256 bytes and prints nothing for
            # them; the CR after it ends the line (one Error) and the version line asks for an answer.
            began = time.monotonic()
            port.write(b"#" * payload)
            wrote = time.monotonic() - began
            port.flush()
            flushed = time.monotonic() - began
            port.write(b"\rversion\r")
            answered = _answer(port, began)
    finally:
        emu.terminate()
        try:
            emu.wait(timeout=10)
        except subprocess.TimeoutExpired:
            emu.kill()
            emu.wait()
    return {"write_s": wrote, "flush_s": flushed, "answer_s": answered,
            "held_bytes": max(0.0, payload - wrote * rate), "version_rtt_ms": statistics.median(rtts),
            "note": f"{payload:,} B: wire {payload / rate:.2f} s, a UART's 4 KB buffer "
                    f"{(payload - UART_XMIT) / rate:.2f} s"}
