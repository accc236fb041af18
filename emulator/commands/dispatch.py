"""The command dispatcher (FIRMWARE-BEHAVIOUR.md#fb-matching, #fb-errors).

The table is the profile's command order; the functions come from the ``COMMANDS`` dict of
``core_commands``, ``device_commands`` and ``drive_commands`` (``name -> fn(hat, cur)``).

A line is a run of commands. Before each command, spaces and ``;`` are skipped; a command
need not be followed by ``;`` (``port 1 vin`` runs both). A token that matches no command,
or a command that raises :class:`CommandError`, prints ``Error``; the rest of the line is
dropped and everything already done stays done.
"""
from __future__ import annotations

from functools import cache
from typing import Callable, Dict, List, Tuple

from . import core_commands, device_commands, drive_commands
from .context import CommandContext
from .parser import CommandError, Cursor, prefix_table

__all__ = ["run_line", "command_table", "ERROR_LINE", "COMMAND_MODULES"]

ERROR_LINE = b"Error"
_MODULES = (core_commands, device_commands, drive_commands)
COMMAND_MODULES = tuple(m.__name__.rsplit(".", 1)[-1] for m in _MODULES)

Command = Callable[[CommandContext, Cursor], None]


def _implementations() -> Dict[str, Command]:
    found: Dict[str, Command] = {}
    for module in _MODULES:
        found.update(module.COMMANDS)
    return found


@cache
def command_table(commands: Tuple[str, ...]) -> Tuple[Tuple[str, ...], Dict[str, Command]]:
    """(names in matching order, name -> function) for a profile's command list.
    A profile naming a command no module implements is a data error, reported at once."""
    impl = _implementations()
    missing = [name for name in commands if name not in impl]
    if missing:
        raise KeyError(f"no implementation for command(s) {missing} (profiles.json vs emulator)")
    return commands, {name: impl[name] for name in commands}


@cache
def _dispatch(commands: Tuple[str, ...]) -> Tuple[Dict[bytes, str], Dict[str, Command]]:
    """(token prefix -> command name, name -> function), built once per command list."""
    names, table = command_table(commands)
    return prefix_table(names), table


def run_line(hat: CommandContext, line: bytes) -> Tuple[bool, List[str], List[str]]:
    """Run every command on the line. Returns (error, commands run, unknown tokens)."""
    prefixes, table = _dispatch(tuple(hat.profile.commands))
    cur = Cursor(line)
    ran: List[str] = []
    unknown: List[str] = []
    while True:
        token, name = cur.next_command(prefixes)
        if not token:
            return False, ran, unknown
        if name is None:
            unknown.append(token.decode("latin-1"))
            hat.emit(ERROR_LINE)
            return True, ran, unknown
        ran.append(name)
        try:
            table[name](hat, cur)
        except CommandError:
            hat.emit(ERROR_LINE)
            return True, ran, unknown
