"""The world actions that reach a port's device (``@data``, ``@rate``, ``@button``, ``@hold``,
``@pos``; routed by emulator/world_actions.py), for anything that holds a device model on a port: the
emulator's own port (emulator/ports/port.py) and the firmware-in-the-loop's (sil/port_world.py).

The holder provides ``device``, ``index`` and ``wake()`` (the device has news: look at it
again); a pressed button changes what the port reads, which ``button_changed()`` reports.
"""
from __future__ import annotations

from typing import Any, Optional

from .active import ActiveDevice
from .motor import MotorDevice
from .passive import PassiveDevice

__all__ = ["PortActions"]


class PortActions:
    device: Optional[Any]
    index: int

    def wake(self) -> None:  # pragma: no cover - provided by the holder
        raise NotImplementedError

    def button_changed(self) -> None:
        """The button's state changed (the holder reads the ID lines again)."""
        self.wake()

    def _active(self, what: str) -> ActiveDevice:
        dev = self.device
        if not isinstance(dev, ActiveDevice):
            raise ValueError(f"{what}: no active device on port {self.index}")
        return dev

    def _motor(self, what: str) -> MotorDevice:
        dev = self.device
        if not isinstance(dev, MotorDevice):
            raise ValueError(f"{what}: no motor on port {self.index}")
        return dev

    def device_data(self, mode: int, payload: Any) -> None:
        """``@data P M HH..`` (payload bytes or a list of ints) / ``@data P M auto`` (None)."""
        data = None if payload is None else bytes(payload)
        self._active("@data").world_data(int(mode), data)
        self.wake()

    def set_data_rate(self, ms: int) -> None:
        self._active("@rate").set_rate(int(ms))
        self.wake()

    def press_button(self, pressed: bool) -> None:
        dev = self.device
        if not isinstance(dev, PassiveDevice):
            raise ValueError(f"@button: no passive device on port {self.index}")
        dev.press(pressed)
        self.button_changed()

    def hold_shaft(self, held: bool) -> None:
        self._motor("@hold").hold(held)
        self.wake()

    def set_shaft_position(self, deg: float) -> None:
        self._motor("@pos").set_position(deg)
        self.wake()
