"""Device commands: list, select, selonce, selrate, combi, write1, write2 (FIRMWARE-BEHAVIOUR.md#fb-arguments,
#fb-list, #fb-data, #fb-device-messages). Each is ``fn(hat, cur)``; a failure raises :class:`CommandError`
after whatever the firmware had already done (partial-failure rules of #fb-errors).
"""
from __future__ import annotations

from typing import List, Tuple

from ..ports import lpf2
from .context import CommandContext
from .parser import CommandError, Cursor

__all__ = ["COMMANDS", "MAX_WRITE_BYTES", "MAX_COMBI_PAIRS"]

MAX_WRITE_BYTES = 128      # a 129th hex token is left for the command parser
MAX_COMBI_PAIRS = 15       # further tokens are parsed as commands


def _clamp(x: int, lo: int, hi: int) -> int:
    return max(lo, min(hi, x))


def cmd_list(hat: CommandContext, cur: Cursor) -> None:
    for port in hat.ports:
        for line in port.describe():
            hat.emit(line)


def _select(hat: CommandContext, cur: Cursor, once: bool) -> None:
    reporter = hat.ports[hat.port].reporter
    mode = cur.try_signed()
    if mode is None:
        reporter.deselect()                  # no argument: stop reporting, send nothing
        return
    mode = _clamp(mode, 0, 15)               # so `select -1` selects mode 0
    offset = cur.try_signed()
    if offset is None:
        reporter.select(mode, once=once)
        return
    offset = _clamp(offset, 0, 127)
    fmt = cur.try_format()
    if fmt is None:
        reporter.bad_format(offset)          # reporting off, offset kept, no SELECT
        raise CommandError("select: missing or bad format")
    reporter.select(mode, offset=offset, fmt=fmt, once=once)


def cmd_select(hat: CommandContext, cur: Cursor) -> None:
    _select(hat, cur, once=False)


def cmd_selonce(hat: CommandContext, cur: Cursor) -> None:
    _select(hat, cur, once=True)


def cmd_selrate(hat: CommandContext, cur: Cursor) -> None:
    hat.ports[hat.port].reporter.set_rate(cur.signed())


def cmd_combi(hat: CommandContext, cur: Cursor) -> None:
    port = hat.ports[hat.port]
    index = _clamp(cur.signed(), 0, 7)
    pairs: List[Tuple[int, int]] = []
    port.combis[index] = pairs               # rewritten in place as pairs parse
    while len(pairs) < MAX_COMBI_PAIRS:
        mode = cur.try_signed()
        if mode is None:
            break
        dataset = cur.try_signed()
        if dataset is None:
            # Odd count: the table keeps the pairs parsed so far; nothing is sent.
            raise CommandError("combi: mode without dataset")
        pairs.append((_clamp(mode, 0, 15), _clamp(dataset, 0, 15)))
    port.send_to_device(lpf2.combi_frame(index, pairs))
    port.reporter.combi_changed()


def _payload(cur: Cursor) -> List[int]:
    out: List[int] = []
    while len(out) < MAX_WRITE_BYTES:
        b = cur.try_hexbyte()
        if b is None:
            break
        out.append(b)
    return out


def cmd_write1(hat: CommandContext, cur: Cursor) -> None:
    header = cur.hexbyte()
    hat.ports[hat.port].send_to_device(lpf2.hat_frame(header, _payload(cur)))


def cmd_write2(hat: CommandContext, cur: Cursor) -> None:
    header = cur.hexbyte()
    second = cur.hex32()
    # FIRMWARE-BEHAVIOUR.md#fb-framing: a second token >= 2^31 is taken as "no second byte".
    b1 = None if second >= 0x80000000 else second & 0xFF
    hat.ports[hat.port].send_to_device(lpf2.hat_frame(header, _payload(cur), b1))


COMMANDS = {
    "list": cmd_list,
    "select": cmd_select,
    "selonce": cmd_selonce,
    "selrate": cmd_selrate,
    "combi": cmd_combi,
    "write1": cmd_write1,
    "write2": cmd_write2,
}
