"""``CommandContext``: what a command (``fn(hat, cur)`` in commands_*.py) may read and change.

Commands work on the global state they set (FIRMWARE-BEHAVIOUR.md#fb-commands) and on the parts of
the HAT as they are (a port's reporter and combi table, a controller's set point and PID, the fault latches),
so this Protocol names the concrete part classes; it lives here rather than in services.py,
which the parts themselves import. ``Hat`` (emulator/hat.py) satisfies it.
"""
from __future__ import annotations

from typing import Optional, Protocol, Sequence

from ..motor.controller import PortController
from ..ports.port import Port
from ..power_faults import FaultMonitor
from ..services import EventLog, Firmware, Output

__all__ = ["CommandContext"]


class CommandContext(Output, EventLog, Firmware, Protocol):
    # The global state (#fb-commands) that commands set.
    port: int
    echo: int
    debug: int
    ledmode: int

    @property
    def vin_mv(self) -> int: ...

    @property
    def version_string(self) -> str: ...

    @property
    def signature(self) -> Optional[bytes]: ...

    @property
    def ports(self) -> Sequence[Port]: ...

    @property
    def controllers(self) -> Sequence[PortController]: ...

    @property
    def faults(self) -> FaultMonitor: ...
