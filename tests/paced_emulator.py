"""An emulator paced at 115200 baud (``buildhat-emulator --baud``), booted and quiet, for the tests of the
command UART's pacing and of the real-time runner, both checked in virtual time."""
from __future__ import annotations

from typing import Dict, Optional

from buildhat_conformance.emulator import Emulator

EMPTY: Dict[int, Optional[str]] = {0: None, 1: None, 2: None, 3: None}
PER_MS = 115200 / 10 / 1000          # 11.52 bytes a millisecond (8N1)


def booted(firmware: str = "R7", devices=EMPTY) -> Emulator:
    """Booted, 50 ms later, its start-up read away."""
    emu = Emulator(firmware=firmware, devices=devices, baud=115200)
    emu.boot()
    emu.advance(50)
    emu.read()
    return emu
