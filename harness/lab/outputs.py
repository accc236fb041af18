"""A place's RESET and BOOT0 lines: two of its labgrid digital outputs, driven as a Pi's GPIO would.

The outputs are the place's resources named ``reset`` and ``boot0`` (the target options
``reset_output=``/``boot0_output=`` name others). Any digital-output resource labgrid can drive
works: the resource class picks labgrid's driver (the table below, as ``labgrid-client io``
picks it), and the driver's ``set(True)`` is the line high. RESET is active low: ``set(False)``
holds the HAT in reset. The sequence is :mod:`..targets.gpio_reset`'s (FIRMWARE-BEHAVIOUR.md#fb-host-update):
BOOT0 low, RESET low 10 ms, high, 10 ms, then 0.5 s for the bootloader to start.
"""
from __future__ import annotations

import time
from typing import Any, Callable, Dict, FrozenSet, List, Optional

from ..targets.base import Control, NeedsCapability, TargetError
from ..targets.gpio_reset import HOLD_S, PULSE_S, SETTLE_S

__all__ = ["LabOutputs", "DRIVER_FOR", "DEFAULT_RESET", "DEFAULT_BOOT0"]

DEFAULT_RESET, DEFAULT_BOOT0 = "reset", "boot0"

#: labgrid digital-output resource class (as the coordinator names it) -> its driver class.
DRIVER_FOR: Dict[str, str] = {
    "HttpDigitalOutput": "HttpDigitalOutputDriver",
    "NetworkSysfsGPIO": "GpioDigitalOutputDriver",          # SysfsGPIO / MatchedSysfsGPIO exported
    "ModbusTCPCoil": "ModbusCoilDriver",
    "WaveshareModbusTCPCoil": "WaveShareModbusCoilDriver",
    "Eth008DigitalOutput": "Eth008DigitalOutputDriver",
    "OneWirePIO": "OneWirePIODriver",
    "NetworkDeditecRelais8": "DeditecRelaisDriver",
    "NetworkLXAIOBusPIO": "LXAIOBusPIODriver",
    "NetworkHIDRelay": "HIDRelayDriver",
}


class LabOutputs(Control):
    """Reset through the place's outputs; ``boot0`` is optional (a HAT's BOOT0 is pulled low)."""

    capabilities: FrozenSet[str] = frozenset({"reset", "bootloader"})

    def __init__(self, reset: Any, boot0: Optional[Any], describe: str,
                 sleep: Callable[[float], None] = time.sleep):
        self._reset, self._boot0, self._describe, self.sleep = reset, boot0, describe, sleep
        self.pulses: List[float] = []

    def action(self, line: str) -> str:
        head = line.split()[0] if line.split() else line
        raise NeedsCapability(head.lstrip("@") or "control",
                              detail="a labgrid place's digital outputs can only reset the HAT")

    def describe(self) -> str:
        return self._describe

    def reset(self, bootloader: bool = False) -> None:
        """The HAT restarts in its bootloader whatever ``bootloader`` says (firmware in RAM)."""
        try:
            if self._boot0 is not None:
                self._boot0.set(False)
            self._reset.set(False)
            self.sleep(PULSE_S)
            self._reset.set(True)
            self.sleep(HOLD_S)
        except Exception as exc:  # noqa: BLE001 - labgrid drivers raise their own kinds
            why = " ".join(str(exc).split()) or type(exc).__name__
            raise TargetError(f"{self._describe}: {why}") from None
        self.pulses.append(time.monotonic())
        self.sleep(SETTLE_S)


def outputs_of(lg_target: Any, place: str, reset_name: str = DEFAULT_RESET,
               boot0_name: str = DEFAULT_BOOT0, required: bool = False) -> Optional[LabOutputs]:
    """The place's reset control, or None when it has no output called ``reset_name`` (then
    TargetError if ``required``, i.e. the option was given)."""
    reset = _driver(lg_target, place, reset_name, required)
    if reset is None:
        return None
    boot0 = _driver(lg_target, place, boot0_name, False)
    what = f"labgrid place {place}: outputs {reset_name!r} (RESET)" + \
        (f", {boot0_name!r} (BOOT0)" if boot0 is not None else "")
    return LabOutputs(reset, boot0, what)


def _driver(lg_target: Any, place: str, name: str, required: bool) -> Optional[Any]:
    from labgrid import target_factory

    found = [r for r in lg_target.resources if getattr(r, "name", None) == name]
    if not found:
        if required:
            names = sorted(str(getattr(r, "name", "")) for r in lg_target.resources
                           if type(r).__name__ in DRIVER_FOR)
            raise TargetError(f"labgrid place {place} has no digital output named {name!r} (its outputs: "
                              f"{', '.join(names) or 'none'})")
        return None
    resource = found[0]
    cls = type(resource).__name__
    driver_name = DRIVER_FOR.get(cls)
    if driver_name is None:
        raise TargetError(f"labgrid place {place}: resource {name!r} is a {cls}, not a digital output "
                          f"this suite drives ({', '.join(sorted(DRIVER_FOR))})")
    driver_cls = target_factory.class_from_string(driver_name)
    # One binding each (labgrid-client does the same for a named output).
    (key,) = driver_cls.bindings
    lg_target.set_binding_map({key: name})
    driver = driver_cls(lg_target, name=name)
    lg_target.activate(driver)
    return driver
