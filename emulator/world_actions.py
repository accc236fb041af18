"""World actions (scenario-script ``@plug``, ``@data``, faults ...) handed to the emulator's objects.

The action line is parsed by ``transcripts.script.parse_world_action`` (one parser for scripts
and the control channel); this table says which object performs it:

| action        | call                                                     | owner |
|---------------|----------------------------------------------------------|-------|
| `@plug P S`   | ``hat.ports[P].plug(spec)``  spec: ("active", 0x30) / ("passive", 8) / None | ports.py |
| `@unplug P`   | ``hat.ports[P].unplug()``                                | ports.py |
| `@data P M H` | ``hat.ports[P].device_data(mode, payload or None)``      | ports.py |
| `@button P S` | ``hat.ports[P].press_button(pressed: bool)``             | ports.py |
| `@rate P MS`  | ``hat.ports[P].set_data_rate(ms)``                       | ports.py |
| `@hold P S`   | ``hat.ports[P].hold_shaft(held: bool)``                  | ports.py / physics |
| `@pos P DEG`  | ``hat.ports[P].set_shaft_position(deg)``                 | ports.py / physics |
| `@motorfault` | ``hat.faults.motor_fault(on, port, flags)``              | faults.py |
| `@portfault`  | ``hat.faults.port_fault(on: bool[, ms])``                | faults.py |
| `@adc RAW`    | ``hat.set_adc(raw)``                                     | hat.py |

A port method that is missing on the Port is looked up on ``port.device`` (the device
model), so a device can own e.g. its shaft. Anything not implemented raises
:class:`WorldError` saying which method is missing.
"""
from __future__ import annotations

from typing import Any, Callable, Dict, Protocol, Sequence, Tuple

from ..serving.hat_model import WorldError
from ..transcripts.script import Action, parse_world_action

__all__ = ["WorldError", "WORLD_HANDLERS", "perform", "perform_line"]


class WorldSide(Protocol):
    """The HAT as world actions reach it (the table above): its ports, its fault monitor, its ADC.
    Methods are looked up by name, so the parts are typed loosely here."""

    @property
    def ports(self) -> Sequence[Any]: ...

    @property
    def faults(self) -> Any: ...

    def set_adc(self, raw: int) -> None: ...


# action -> (where: "port" | "faults" | "hat", method name, how the parsed args map to the call)
WORLD_HANDLERS: Dict[str, Tuple[str, str, Callable[[tuple], tuple]]] = {
    "plug": ("port", "plug", lambda a: (a[1],)),
    "unplug": ("port", "unplug", lambda a: ()),
    "data": ("port", "device_data", lambda a: (a[1], a[2])),
    "button": ("port", "press_button", lambda a: (bool(a[1]),)),
    "rate": ("port", "set_data_rate", lambda a: (a[1],)),
    "hold": ("port", "hold_shaft", lambda a: (bool(a[1]),)),
    "pos": ("port", "set_shaft_position", lambda a: (a[1],)),
    "motorfault": ("faults", "motor_fault", lambda a: (bool(a[0]), a[1], a[2])),
    "portfault": ("faults", "port_fault", lambda a: (bool(a[0]),) + tuple(a[1:])),
    "adc": ("hat", "set_adc", lambda a: (a[0],)),
}


def _target(hat: WorldSide, where: str, method: str, args: tuple) -> Any:
    if where == "hat":
        return hat
    if where == "faults":
        return hat.faults
    port = hat.ports[args[0]]
    if not hasattr(port, method) and hasattr(getattr(port, "device", None), method):
        return port.device
    return port


def perform(hat: WorldSide, action: Action) -> None:
    """Carry out one parsed world action on ``hat``."""
    try:
        where, method, mapper = WORLD_HANDLERS[action.kind]
    except KeyError:
        raise WorldError(f"@{action.kind} is not a world action") from None
    target = _target(hat, where, method, action.args)
    fn = getattr(target, method, None)
    if fn is None:
        raise WorldError(f"@{action.kind} is not implemented by this emulator build "
                         f"({type(target).__name__}.{method} is missing)")
    try:
        fn(*mapper(action.args))
    except (ValueError, KeyError) as exc:
        raise WorldError(f"@{action.kind}: {exc.args[0] if exc.args else exc}") from None


def perform_line(hat: WorldSide, line: str) -> None:
    """Parse (``transcripts.script.parse_world_action``) and perform one world-action line."""
    try:
        action = parse_world_action(line)
    except ValueError as exc:
        raise WorldError(str(exc)) from None
    perform(hat, action)
