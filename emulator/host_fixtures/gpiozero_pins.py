"""A gpiozero pin factory that wires the Build HAT's RESET and BOOT0 pins to ``buildhat-emulator``.

A host library resets a real HAT through the Raspberry Pi's GPIO header (RESET = GPIO 4, active low;
BOOT0 = GPIO 22). With this factory the same gpiozero calls reach the emulator instead, through its
control channel (``@gpio PIN LEVEL``, serving/reset_pins.py), so a library's reset -> bootloader ->
upload -> reboot runs unmodified:

    buildhat-emulator --pty --control /tmp/bh.ctl ...     # prints BUILDHAT_EMULATOR_CONTROL=/tmp/bh.ctl
    export BUILDHAT_EMULATOR_CONTROL=/tmp/bh.ctl           # (+ BUILDHAT_EMULATOR_TOKEN=... on TCP)
    GPIOZERO_PIN_FACTORY=buildhat_emulator python my_buildhat_program.py

The factory is registered under gpiozero's own plug-in entry point (``gpiozero_pin_factories`` in
pyproject.toml), so installing this package is all a host environment needs. Every other pin behaves as
gpiozero's mock pin (a Raspberry Pi 3B with nothing attached). Imports only gpiozero and the standard library.
"""
from __future__ import annotations

from typing import Any, Optional

from gpiozero.exc import BadPinFactory
from gpiozero.pins.mock import MockFactory, MockPin

from ...serving.control_client import ENV_ADDRESS, ControlClient, ControlError

__all__ = ["EmulatorPinFactory", "EmulatorPin", "HAT_PINS"]

#: gpiozero's name of the BCM GPIO -> the pin name ``@gpio`` takes.
HAT_PINS = {"GPIO4": "reset", "GPIO22": "boot0"}


class EmulatorPin(MockPin):
    """A mock pin that, on GPIO 4 or 22, tells the emulator the level it drives (``z`` as an input)."""

    def __init__(self, factory: Any, info: Any):
        super().__init__(factory, info)
        self._sent: Optional[str] = None

    def _set_function(self, value: str) -> None:
        super()._set_function(value)
        self._tell()

    def _set_state(self, value: Any) -> None:
        super()._set_state(value)
        self._tell()

    def _tell(self) -> None:
        name = HAT_PINS.get(self.info.name)     # (info.number is the header pin: 7 for GPIO4)
        if name is None:
            return
        level = ("1" if self._state else "0") if self._function == "output" else "z"
        if level != self._sent:
            self.factory.gpio(name, level)
            self._sent = level


class EmulatorPinFactory(MockFactory):
    """gpiozero factory ``buildhat_emulator``: the control channel from ``BUILDHAT_EMULATOR_CONTROL``."""

    def __init__(self, revision: Optional[str] = None):
        super().__init__(revision=revision, pin_class=EmulatorPin)
        try:
            self.client = ControlClient.from_environment()
            self.client.connect(wait=5.0)
        except ControlError as exc:
            raise BadPinFactory(f"buildhat_emulator pin factory: {exc}") from None

    def gpio(self, name: str, level: str) -> None:
        reply = self.client.request(f"@gpio {name} {level}")
        if reply != "ok":
            raise BadPinFactory(f"buildhat_emulator pin factory: {ENV_ADDRESS} answered {reply!r} "
                                f"to @gpio {name} {level}")

    def close(self) -> None:
        self.client.close()
        super().close()
