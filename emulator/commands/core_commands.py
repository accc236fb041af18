"""Command-port commands that touch no device or motor (FIRMWARE-BEHAVIOUR.md#fb-arguments,
#fb-commands, #fb-vin).

help/?, port, vin, ledmode, echo, debug, version, signature. Each is ``fn(hat, cur)``.
"""
from __future__ import annotations

from typing import Callable, Dict

from .context import CommandContext
from .parser import Cursor

__all__ = ["COMMANDS", "format_vin", "UNKNOWN_SIGNATURE"]

# R4 shipped in no host-library release, so its signature.bin is unknown. The emulator
# prints 64 zero bytes for it and says so in a `note` event; a real R4 prints its own bytes.
UNKNOWN_SIGNATURE = bytes(64)


def cmd_help(hat: CommandContext, cur: Cursor) -> None:
    hat.write_out(hat.profile.help_bytes)


def cmd_port(hat: CommandContext, cur: Cursor) -> None:
    hat.port = min(cur.unsigned(), 3)     # unsigned: `port -1` fails; large values clamp


def format_vin(mv: int) -> str:
    """#fb-vin: hundredths rounded with a third decimal of 5 going down."""
    k = (mv + 4) // 10
    return f"{k // 100}.{k % 100:02d} V"


def cmd_vin(hat: CommandContext, cur: Cursor) -> None:
    hat.emit(format_vin(hat.vin_mv))


def cmd_ledmode(hat: CommandContext, cur: Cursor) -> None:
    hat.ledmode = max(-1, min(cur.signed(), 3))


def cmd_echo(hat: CommandContext, cur: Cursor) -> None:
    hat.echo = cur.signed()


def cmd_debug(hat: CommandContext, cur: Cursor) -> None:
    hat.debug = cur.signed()


def cmd_version(hat: CommandContext, cur: Cursor) -> None:
    hat.emit("Firmware version: " + hat.version_string)


def cmd_signature(hat: CommandContext, cur: Cursor) -> None:
    sig = hat.signature
    if sig is None:
        sig = UNKNOWN_SIGNATURE
        hat.note(f"the signature of {hat.profile.name} is unknown; the emulator printed 64 zero bytes")
    hat.emit(b"Firmware signature:" + b"".join(b" %02X" % b for b in sig))


COMMANDS: Dict[str, Callable[[CommandContext, Cursor], None]] = {
    "help": cmd_help,
    "?": cmd_help,
    "port": cmd_port,
    "vin": cmd_vin,
    "ledmode": cmd_ledmode,
    "echo": cmd_echo,
    "debug": cmd_debug,
    "version": cmd_version,
    "signature": cmd_signature,
}
