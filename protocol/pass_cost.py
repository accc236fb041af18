"""What one main-loop pass costs on the HAT, for the ``deltat=`` stall line (FIRMWARE-BEHAVIOUR.md#fb-stall).

The firmware's loop measures the milliseconds since its last pass; a pass that took more than
``stall_line_above_ms`` prints ``deltat=XXXXXXXX`` at the start of the next pass. A command runs
in the pass that received its CR, so a long ``list`` (hundreds of numbers formatted in software
floating point on a 133 MHz Cortex-M0+) stretches that pass. The constants are profile data
(``main_loop_cost`` in protocol/profiles.json) and docs/EMULATOR-MODELS.md explains them:

    line    = line_us
            + for each `list` on the line: 4 x list_port_us + list_device_us per active device
                                          + list_byte_us per byte of the dump
            + text_byte_us per other byte the line wrote (help text, echo, error lines ...)
"""
from __future__ import annotations

from typing import Iterable, Protocol, Sequence

__all__ = ["PassCost", "stall_line", "ListedPort"]


class ListedPort(Protocol):
    """What the cost model reads from a port: is an active device established, and its dump."""

    established: bool

    def describe(self) -> list: ...


def stall_line(deltat_ms: int) -> bytes:
    """The firmware's stall line, without CRLF: ``deltat=`` and 8 upper-case hex digits."""
    return b"deltat=%08X" % (deltat_ms & 0xFFFFFFFF)


class PassCost:
    """The cost model of one profile (``Profile.features``)."""

    def __init__(self, features: dict):
        cost = features.get("main_loop_cost") or {}
        self.line_us = float(cost.get("line_us", 0))
        self.text_byte_us = float(cost.get("text_byte_us", 0))
        self.list_port_us = float(cost.get("list_port_us", 0))
        self.list_device_us = float(cost.get("list_device_us", 0))
        self.list_byte_us = float(cost.get("list_byte_us", 0))
        self.stall_above_ms = int(features.get("stall_line_above_ms", 2))

    def list_us(self, ports: Iterable[ListedPort]) -> tuple[float, int]:
        """(cost in µs, bytes written) of one ``list`` over ``ports`` as they are now."""
        us = 0.0
        nbytes = 0
        for port in ports:
            lines = port.describe()
            size = sum(len(line) + 2 for line in lines)      # + CRLF
            nbytes += size
            us += self.list_port_us + size * self.list_byte_us
            if port.established:
                us += self.list_device_us
        return us, nbytes

    def line_cost_us(self, commands: Sequence[str], written: int,
                     ports: Sequence[ListedPort]) -> float:
        """µs of the pass that ran ``commands`` and wrote ``written`` bytes in all."""
        us = self.line_us
        lists = commands.count("list")
        if lists:
            list_us, list_bytes = self.list_us(ports)
            us += lists * list_us
            written = max(0, written - lists * list_bytes)
        return us + written * self.text_byte_us

    def prints_stall(self, deltat_ms: int) -> bool:
        """The firmware prints the stall line when ``deltat > 2`` (#fb-stall, #fb-timing)."""
        return deltat_ms > self.stall_above_ms
