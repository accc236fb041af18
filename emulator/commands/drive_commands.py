"""Motor-drive commands (FIRMWARE-BEHAVIOUR.md#fb-errors, #fb-commands, #fb-controller): each is
``fn(hat, cur)``.

clear_faults, pwm, coast, on, off, set, pid, pid_diff, bias, plimit, port_plimit, pwmparams.
They write the state of ``hat.controllers[hat.port]`` (``emulator/motor/controller.py``); the 10 ms
controller update does the rest. A bad or missing argument raises :class:`CommandError`; what
was stored before the failure stays stored, exactly where the firmware stores field by field
(``pid``, ``set var``), and nothing changes where it parses everything first (``set <wave>``,
``pwmparams``).
"""
from __future__ import annotations

from typing import Callable, Dict

from ..motor.controller import MODE_PID, MODE_PID_DIFF, MODE_PWM, PortController
from ..motor.pid import SensorVariable
from ..motor.pwm_drive import param_q16
from .context import CommandContext
from .parser import CommandError, Cursor

__all__ = ["COMMANDS", "parse_svar"]

_MAX_PORT, _MAX_MODE, _MAX_OFFSET = 3, 15, 127


def _ctl(hat: CommandContext) -> PortController:
    return hat.controllers[hat.port]


def cmd_clear_faults(hat: CommandContext, cur: Cursor) -> None:
    hat.faults.clear_faults()
    for controller in hat.controllers:       # it writes every driver's flag register
        controller.clear_faults()


def cmd_pwm(hat: CommandContext, cur: Cursor) -> None:
    c = _ctl(hat)
    c.pwmmode = MODE_PWM
    c.coast = False
    c.setpoint = 0.0      # the generator is untouched, so the next tick brings the set point back


def cmd_coast(hat: CommandContext, cur: Cursor) -> None:
    _ctl(hat).coast = True


def _constant(hat: CommandContext, value: float) -> None:
    c = _ctl(hat)
    c.generator.set_constant(value)
    c.coast = False


def cmd_on(hat: CommandContext, cur: Cursor) -> None:
    # Despite the help text, on/off do not switch to PWM mode (#fb-on-off).
    _constant(hat, 1.0)


def cmd_off(hat: CommandContext, cur: Cursor) -> None:
    _constant(hat, 0.0)


def parse_svar(cur: Cursor, svar: SensorVariable) -> None:
    """``<port> <mode> <offset> <format> <scale> <unwrap>``, each field stored as soon as it
    parses (so a failure part-way leaves the earlier fields updated)."""
    svar.port = min(cur.unsigned(), _MAX_PORT)
    svar.mode = min(cur.unsigned(), _MAX_MODE)
    svar.offset = min(cur.unsigned(), _MAX_OFFSET)
    svar.format = cur.format()
    svar.scale = cur.float()          # not clamped (the firmware clamps the wrong variable)
    svar.unwrap = cur.float()


def cmd_set(hat: CommandContext, cur: Cursor) -> None:
    c = _ctl(hat)
    shape = cur.match(hat.profile.set_keywords)
    if shape is None:
        value = cur.float()
        _constant(hat, value)
        return
    if shape == "var":
        # set var <min> <max> <slope> <offset> <svar> (R6+).
        vmin, vmax, slope, offset = cur.float(), cur.float(), cur.float(), cur.float()
        c.generator.set_var_map(vmin, vmax, slope, offset)
        c.coast = False
        c.var.restart()
        parse_svar(cur, c.var)
        return
    a, b, period, phase = cur.float(), cur.float(), cur.float(), cur.float()
    c.generator.set_wave(shape, a, b, period, phase)
    c.coast = False


def _pid(hat: CommandContext, cur: Cursor, mode: int) -> None:
    c = _ctl(hat)
    c.pv.restart()
    pid = c.pid
    try:
        parse_svar(cur, c.pv)
        pid.kp = cur.float()
        pid.ki = cur.float()
        pid.kd = cur.float()
        pid.windup = cur.float()
        if hat.profile.feature("pid_numbers") >= 11:
            pid.deadzone = cur.float()
    except CommandError:
        # cmd_pid's error path: fields already parsed stay stored, the port goes to PWM mode.
        c.pwmmode = MODE_PWM
        c.coast = False
        raise
    c.pwmmode = mode
    c.coast = False


def cmd_pid(hat: CommandContext, cur: Cursor) -> None:
    _pid(hat, cur, MODE_PID)


def cmd_pid_diff(hat: CommandContext, cur: Cursor) -> None:
    _pid(hat, cur, MODE_PID_DIFF)


def cmd_bias(hat: CommandContext, cur: Cursor) -> None:
    _ctl(hat).drive.bias = param_q16(cur.float())


def cmd_plimit(hat: CommandContext, cur: Cursor) -> None:
    # R1-R5 keep one global limit and R6+ write all four per-port limits: either way every
    # port gets the value; the difference is whether a port reset restores 0.1 (drive.py).
    limit = param_q16(cur.float())
    for c in hat.controllers:
        c.drive.limit = limit


def cmd_port_plimit(hat: CommandContext, cur: Cursor) -> None:
    _ctl(hat).drive.limit = param_q16(cur.float())


def cmd_pwmparams(hat: CommandContext, cur: Cursor) -> None:
    thresh, minpwm = cur.float(), cur.float()      # both must parse, or nothing changes
    d = _ctl(hat).drive
    d.pwmthresh = param_q16(thresh)
    d.minpwm = param_q16(minpwm)


COMMANDS: Dict[str, Callable[[CommandContext, Cursor], None]] = {
    "clear_faults": cmd_clear_faults,
    "pwm": cmd_pwm,
    "coast": cmd_coast,
    "on": cmd_on,
    "off": cmd_off,
    "set": cmd_set,
    "pid": cmd_pid,
    "pid_diff": cmd_pid_diff,
    "bias": cmd_bias,
    "plimit": cmd_plimit,
    "port_plimit": cmd_port_plimit,
    "pwmparams": cmd_pwmparams,
}
