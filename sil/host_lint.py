"""The host lint on a served firmware (``sil serve``): the same findings as ``buildhat-emulator`` gives.

The lint (``serving/host_lint/lint.py``) judges each host line from a record of what the HAT did with it:
which words were commands, which were none, whether the line failed, whether the start-up was done,
and what the transmit ring had to drop. A firmware built for the host keeps all that inside its own
code, where the stand-in cannot see it. So the lint reads each line through a *shadow*: the emulator
as the release the firmware reports, with the same devices, fed the same host bytes at the same HAT
times and paced at the same 115200 baud (docs/FIRMWARE-BEHAVIOUR.md#fb-uart). The shadow's answers
are thrown away; only its line records reach the lint. Where the emulator models the firmware line
for line (docs/EMULATOR-MODELS.md), the lint therefore says of a host session on ``sil serve`` what it
says of the same session on the emulator.

:class:`FirmwareLint` is a :class:`~..emulator.hostlint.HostLint` whose ``follow`` keeps the shadow in
step with the served firmware (time, a power-cycle, devices plugged or unplugged) and whose
``feed_input`` hands the shadow the host's bytes; the real-time runner and the control channel call
both as they do for the emulator.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Dict, Optional

from ..emulator.api import Emulator
from ..protocol.devices import format_device_spec
from ..serving.host_lint.lint import HostLint

__all__ = ["FirmwareLint", "LINT_BAUD"]

LINT_BAUD = 115200      # the command port's wire (docs/FIRMWARE-BEHAVIOUR.md#fb-uart)


@dataclass
class FirmwareLint(HostLint):
    """A host lint for a served :class:`~.hat.SilHat`: see the module's docstring."""

    firmware: Any = None               # the served SilHat
    release: Optional[str] = None      # the release number the firmware reports (None: latest)
    booted: bool = False               # the firmware was served with its start-up done
    _shadow: Optional[Emulator] = None
    _powered_at: int = 0               # the firmware's last power-on (SilHat.power_on_ms)

    def follow(self, emulator: Any) -> None:
        """Keep the shadow where ``emulator`` (the served firmware) is; attach to the shadow's HAT."""
        hat = self.firmware if self.firmware is not None else emulator
        if self._shadow is None:
            self._shadow = Emulator(firmware=self.release, devices=dict(getattr(hat, "devices", {})),
                                    seed=int(getattr(hat, "seed", 0)), baud=LINT_BAUD, record_events=False)
            if self.booted:
                self._shadow.boot()
            self._powered_at = int(getattr(hat, "power_on_ms", 0))
        shadow = self._shadow
        power_on = int(getattr(hat, "power_on_ms", 0))
        if power_on != self._powered_at:           # the firmware was power-cycled (@reset): so is the shadow
            self._advance(shadow, power_on)
            shadow.reset()
            self._powered_at = power_on
        self._match_devices(shadow, getattr(hat, "devices", {}))
        self._advance(shadow, int(hat.now))
        super().follow(shadow)

    def feed_input(self, data: bytes) -> None:
        super().feed_input(data)
        if self.firmware is not None:
            self.follow(self.firmware)            # the bytes arrive at the firmware's now
        if self._shadow is not None:
            self._shadow.write(data)

    @staticmethod
    def _advance(shadow: Emulator, now: int) -> None:
        if now > shadow.now:
            shadow.advance(now - shadow.now)
        shadow.read()                  # the shadow's answers reach nobody

    @staticmethod
    def _match_devices(shadow: Emulator, devices: Dict[int, Any]) -> None:
        for port, spec in devices.items():
            if shadow.devices.get(port) == spec:
                continue
            if spec is None:
                shadow.world(f"@unplug {port}")
            else:
                shadow.world(f"@plug {port} {format_device_spec(spec)}")
            shadow.devices[port] = spec
