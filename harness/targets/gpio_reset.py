"""Resetting a Build HAT from a Raspberry Pi: its RESET and BOOT0 lines through libgpiod v2.

The HAT's RESET is on header GPIO 4 and BOOT0 on GPIO 22. The sequence is the one the
official library uses (FIRMWARE-BEHAVIOUR.md#fb-host-update): BOOT0 held low (boot from flash, i.e. into the
bootloader; high would start the chip's own USB boot ROM), RESET low for 10 ms, high again,
10 ms later both lines released, then 0.5 s for the bootloader to start. The firmware lives
in RAM, so after any reset the HAT is in its bootloader (``BHBL>``) and needs ``load``.

Chosen with the target option ``?reset=gpio`` (``&chip=/dev/gpiochip0&reset_line=4&boot0_line=22``,
the defaults; docs/LAB.md says which chip a Pi 4 and a Pi 5 have). ``request_lines`` may be
replaced (tests use a fake chip); it is called exactly like ``gpiod.request_lines``.
"""
from __future__ import annotations

import errno
import os
import time
from typing import Any, Callable, Dict, FrozenSet, List, Optional

from ...plumbing.optional_extras import install_hint
from .base import Control, NeedsCapability, TargetError

__all__ = ["GpioReset", "gpio_reset_from_options", "GPIO_OPTIONS", "DEFAULT_CHIP", "RESET_LINE", "BOOT0_LINE",
           "PULSE_S", "SETTLE_S"]

DEFAULT_CHIP = "/dev/gpiochip0"
RESET_LINE = 4
BOOT0_LINE = 22
PULSE_S = 0.01          # RESET low
HOLD_S = 0.01           # RESET high again before the lines are released
SETTLE_S = 0.5          # the bootloader starts and prints its banner
GPIO_OPTIONS = ("reset", "chip", "reset_line", "boot0_line")
_CONSUMER = "buildhat-conformance"


class GpioReset(Control):
    """A :class:`Control` that can do one thing: pulse the HAT's reset line."""

    capabilities: FrozenSet[str] = frozenset({"reset", "bootloader"})

    def __init__(self, chip: str = DEFAULT_CHIP, reset_line: int = RESET_LINE, boot0_line: int = BOOT0_LINE,
                 request_lines: Optional[Callable[..., Any]] = None,
                 sleep: Callable[[float], None] = time.sleep):
        if reset_line == boot0_line:
            raise TargetError(f"reset_line and boot0_line are both GPIO {reset_line}; they are two lines")
        self.chip = chip if chip.startswith("/") else "/dev/" + chip
        self.reset_line, self.boot0_line = int(reset_line), int(boot0_line)
        self._request_lines = request_lines
        self.sleep = sleep
        self.pulses: List[float] = []        # monotonic time of every reset, for reports

    def action(self, line: str) -> str:
        head = line.split()[0] if line.split() else line
        raise NeedsCapability(head.lstrip("@") or "control",
                              detail="a HAT reset through GPIO can only reset it")

    def describe(self) -> str:
        return f"GPIO reset: {self.chip} line {self.reset_line} (RESET), line {self.boot0_line} (BOOT0)"

    def reset(self, bootloader: bool = False) -> None:
        """Pulse RESET with BOOT0 low. The HAT restarts in its bootloader whatever ``bootloader``
        says (its firmware is in RAM): callers then load the image again."""
        from gpiod import LineSettings
        from gpiod.line import Direction, Value

        request = self._request(LineSettings, Direction, Value)
        try:
            request.set_value(self.reset_line, Value.INACTIVE)     # RESET low: the chip stops
            self.sleep(PULSE_S)
            request.set_value(self.reset_line, Value.ACTIVE)       # RESET high: it starts, from flash
            self.sleep(HOLD_S)
        finally:
            request.release()
        self.pulses.append(time.monotonic())
        self.sleep(SETTLE_S)

    def _request(self, LineSettings: Any, Direction: Any, Value: Any) -> Any:
        config: Dict[Any, Any] = {
            # BOOT0 low first and all along; RESET starts high (not in reset) so the pulse is ours.
            self.boot0_line: LineSettings(direction=Direction.OUTPUT, output_value=Value.INACTIVE),
            self.reset_line: LineSettings(direction=Direction.OUTPUT, output_value=Value.ACTIVE),
        }
        request_lines = self._request_lines
        if request_lines is None:
            import gpiod
            if not os.path.exists(self.chip) or not gpiod.is_gpiochip_device(self.chip):
                raise TargetError(f"no GPIO chip at {self.chip}: list the chips with `gpiodetect` and "
                                  "give the one with the header's lines (gpioinfo shows GPIO4/GPIO22) as "
                                  "&chip=/dev/gpiochipN (docs/LAB.md)")
            request_lines = gpiod.request_lines
        try:
            return request_lines(self.chip, consumer=_CONSUMER, config=config)
        except PermissionError:
            raise TargetError(f"permission denied opening {self.chip}: add your user to the 'gpio' group "
                              "(sudo usermod -aG gpio $USER, then log in again)") from None
        except OSError as exc:
            if exc.errno == errno.EBUSY:
                raise TargetError(f"GPIO lines {self.reset_line}/{self.boot0_line} on {self.chip} are busy: "
                                  "another program holds them (`gpioinfo` shows the consumer)") from None
            raise TargetError(f"cannot request GPIO lines {self.reset_line}/{self.boot0_line} on "
                              f"{self.chip}: {exc}") from None


def gpio_reset_from_options(values: Dict[str, str], url: str,
                            request_lines: Optional[Callable[..., Any]] = None) -> Optional[GpioReset]:
    """The reset control for a target URL's options (``reset``, ``chip``, ``reset_line``,
    ``boot0_line``; already split from the query), or None without ``reset=``."""
    kind = values.get("reset")
    extra = [k for k in ("chip", "reset_line", "boot0_line") if k in values]
    if kind is None:
        if extra:
            raise TargetError(f"{url}: {', '.join(extra)} mean something only with reset=gpio")
        return None
    if kind != "gpio":
        raise TargetError(f"{url}: reset={kind!r} is not known; the one way is reset=gpio (a Raspberry Pi's "
                          f"GPIO lines, needs the gpiod package: {install_hint('gpio')})")
    if request_lines is None:
        try:
            import gpiod  # noqa: F401 - only to say now, in one line, that it is missing
        except ImportError:
            raise TargetError(f"{url}: reset=gpio needs the gpiod package (libgpiod v2 bindings): "
                              f"{install_hint('gpio')}") from None
    lines = {}
    for key, default in (("reset_line", RESET_LINE), ("boot0_line", BOOT0_LINE)):
        text = values.get(key, str(default))
        if not text.isdigit():
            raise TargetError(f"{url}: {key} must be a GPIO line number, got {text!r}")
        lines[key] = int(text)
    return GpioReset(values.get("chip", DEFAULT_CHIP), lines["reset_line"], lines["boot0_line"],
                     request_lines=request_lines)
