"""What the parts of the emulated HAT may use of it: one ``typing.Protocol`` per part.

``Hat`` (emulator/hat.py) is the composition root: it builds the ports, controllers, fault
monitor and start-up and hands each of them itself, seen through the Protocol below that the
part declares (``Port(hat: PortServices, index)``). A part may touch only what its Protocol
names, and no part imports hat.py, not even for typing (tests/emulator/test_layering.py keeps it
so): a part can be built and ticked with a small fake instead of a whole HAT
(tests/emulator/test_services.py). The command modules see the HAT through ``CommandContext``
(emulator/commands/context.py), which needs the concrete part classes and so lives beside them;
a ``Reporter`` sees its port as ``reporting.ReporterPort``. This module imports no part of the
emulator (only ``drive.Duty``), so any part may import it.

The services, by job:

- output:      ``emit(line)`` (CRLF added), ``write_out(bytes)`` (raw), ``tx_pending()``
- transcript:  ``event(kind, **fields)``, ``note(text)``
- scheduling:  ``wake()`` (something is due earlier than the HAT last noted), ``now`` (virtual ms)
- global state (FIRMWARE-BEHAVIOUR.md#fb-commands): ``profile``, ``debug``, ``seed``
- the sibling parts, each seen through its own small view: ``ports``, ``controllers``, ``faults``
"""
from __future__ import annotations

from typing import Any, Optional, Protocol, Sequence, Union

from ..protocol.profiles import Profile
from .motor.pwm_drive import Duty

__all__ = ["Duty", "Output", "EventLog", "Scheduler", "Clock", "Firmware", "DebugBits", "Wakeable",
           "PortLink", "ControllerLink", "FaultLink", "InputRing", "PortServices", "LinkServices",
           "UartServices", "ControllerServices", "FaultServices", "StartupServices", "DevicePort"]


# -- the services, by job --------------------------------------------------------------------
class Output(Protocol):
    def emit(self, line: Union[bytes, str]) -> None:
        """One output line on the command port; CRLF is added."""
        ...

    def write_out(self, data: bytes) -> None:
        """Raw output bytes (no CRLF)."""
        ...


class EventLog(Protocol):
    def event(self, kind: str, **fields: Any) -> None:
        """A transcript event (``dev``, ``devrx``, ``pwm``, ``led``, ``note``) at the current time."""
        ...

    def note(self, text: str) -> None: ...


class Scheduler(Protocol):
    def wake(self) -> None:
        """Something is due earlier than the HAT last noted: look at every part again."""
        ...


class Clock(Protocol):
    @property
    def now(self) -> int:
        """Virtual milliseconds since power-on."""
        ...


class Firmware(Protocol):
    @property
    def profile(self) -> Profile:
        """The release being emulated (protocol/profiles.json)."""
        ...


class DebugBits(Protocol):
    @property
    def debug(self) -> int:
        """The ``debug`` bits (#fb-debug)."""
        ...


# -- the sibling parts, as the others see them ----------------------------------------------------
class Wakeable(Protocol):
    def wake(self) -> None: ...


class PortLink(Wakeable, Protocol):
    """A port as its controller sees it."""

    @property
    def connected(self) -> bool: ...

    def mode_data(self, mode: int) -> Optional[bytes]: ...


class ControllerLink(Protocol):
    """A port's motor controller as the port (and the device on it) sees it."""

    def reset(self) -> None: ...

    def autopower(self) -> None: ...

    def motor_output(self) -> Duty: ...


class FaultLink(Protocol):
    """The fault monitor as a controller sees it."""

    def output_disabled(self, port: int) -> bool: ...


class InputRing(Protocol):
    """The command port's receive ring as the start-up's discard loop sees it."""

    def read_byte(self) -> Optional[int]: ...


# -- what each part receives ------------------------------------------------------------------
class PortServices(Output, EventLog, Scheduler, Clock, Firmware, DebugBits, Protocol):
    """``Port`` (emulator/ports/port.py), its ``Reporter`` and the device models reached through it."""

    @property
    def seed(self) -> int: ...

    def tx_pending(self) -> int:
        """Bytes queued for the host (R5+ report throttle, #fb-reporting-r5)."""
        ...

    @property
    def controllers(self) -> Sequence[ControllerLink]: ...


class LinkServices(Output, DebugBits, Protocol):
    """``DeviceConversation`` (emulator/ports/device_conversation.py)."""


class UartServices(Output, EventLog, DebugBits, Protocol):
    """``PortUart`` (emulator/ports/device_uart.py)."""


class ControllerServices(Output, Firmware, DebugBits, Protocol):
    """``PortController`` (emulator/motor/controller.py)."""

    def set_drive(self, port: int, duty: Duty) -> None:
        """The motor driver of ``port`` now outputs ``duty``."""
        ...

    @property
    def ports(self) -> Sequence[PortLink]: ...

    @property
    def faults(self) -> FaultLink: ...


class FaultServices(Output, Scheduler, Firmware, Clock, Protocol):
    """``FaultMonitor`` (emulator/power_faults.py)."""

    @property
    def ports(self) -> Sequence[Wakeable]: ...


class StartupServices(Output, Clock, Protocol):
    """``Startup`` (emulator/startup.py)."""

    @property
    def uart(self) -> InputRing: ...


class DevicePort(Protocol):
    """A port as the device model plugged into it (emulator/devices/) sees it."""

    @property
    def hat(self) -> PortServices: ...

    @property
    def index(self) -> int: ...
