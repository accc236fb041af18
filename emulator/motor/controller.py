"""One port's motor controller: the 10 ms update of FIRMWARE-BEHAVIOUR.md#fb-controller (``proc_pwm``).

``Hat`` builds ``PortController(hat, index)`` for ports 0..3 and calls ``tick(now)`` every
millisecond; the controller runs its own drift-free 10 ms timer. Each update:
(1) step the set-point generator (``emulator/motor/waveforms.py``) and print ``P<p>: pulse done`` /
``ramp done`` when a pulse/ramp ends - even on an empty port; (2) no device connected ->
drive 0; (3) coast -> coast; (4) PWM mode -> drive the set point; (5) PID mode -> read the
process variable (``emulator/motor/pid.py``; no data yet -> leave the output as it is), print the
debug-16 line when ``hat.debug & 16``, drive the PID output. Driving goes through
``emulator/motor/pwm_drive.py`` and reaches the HAT (``hat.set_drive(port, duty)``, which records the
``pwm`` transcript event) only when the duty changes.

State (what the commands in ``emulator/commands/drive_commands.py`` write):
- ``pwmmode``: 0 direct PWM, 1 PID, 2 PID on the differentiated PV (``pid_diff``, R6+)
- ``coast``: bool; cleared by pwm, pid*, set, on, off
- ``setpoint``: the last set-point value (``pwm`` zeroes it; the next tick regenerates it)
- ``generator``: :class:`SetpointGenerator` (constant / waveform / ``var``)
- ``pv``: :class:`SensorVariable` of the PID; ``var``: the one of ``set var`` (R6+)
- ``pid``: :class:`Pid` gains and state
- ``drive``: :class:`DrivePath` (bias, pwmthresh/minpwm, limit in Q16)
- ``duty``: the last value written to the driver (+-255 or ``"coast"``); 0 at boot
- ``output``: what the driver puts out; ``duty``, except after ``clear_faults`` (:meth:`clear_faults`)

``reset()`` is the firmware's ``port_initpwm`` (#fb-port-reset); the port state machine
(``emulator/ports/port.py``) calls it every time the port passes state 0. It clears pwmmode, coast,
set point and generator (constant 0, period 1), PID gains and state, both svars, bias
(R1-R5) or pwmthresh/minpwm and - when ``plimit_scope`` is ``per_port`` (R6+) - the limit
(back to 0.1). It does not touch ``duty``.

Uses from other modules:
- ``hat.ports[p].connected`` -> bool: the firmware's "device connected" flag (passive device
  connected, or active device established).
- ``hat.ports[p].mode_data(mode)`` -> Optional[bytes]: the latest payload stored for that
  mode, None if the mode never received data since the port reset.
- ``hat.faults.output_disabled(p)`` (``emulator/power_faults.py``): a latched motor fault switches
  the driver output off; see :meth:`motor_output`, which motor models read.
"""
from __future__ import annotations

from typing import Optional

from ..commands.printers import format_float
from ..services import ControllerServices
from .pid import Pid, PidStep, SensorVariable
from .pwm_drive import COAST, DrivePath, Duty
from .waveforms import SetpointGenerator

__all__ = ["PortController", "PWM_UPDATE_MS", "MODE_PWM", "MODE_PID", "MODE_PID_DIFF"]

PWM_UPDATE_MS = 10
MODE_PWM, MODE_PID, MODE_PID_DIFF = 0, 1, 2


class PortController:
    """Set point, PID and drive path of one port (see the module docstring)."""

    def __init__(self, hat: ControllerServices, index: int) -> None:
        self.hat = hat          # the HAT as far as a controller may use it
        self.index = index
        features = hat.profile.features
        self.per_port_limit = features["plimit_scope"] == "per_port"
        self.generator = SetpointGenerator()
        self.pv = SensorVariable(features["unwrap_init"])
        self.var = SensorVariable(features["unwrap_init"])
        self.pid = Pid(features["pid_deadzone"])
        self.drive = DrivePath(biased=hat.profile.has("bias"))
        self.duty: Duty = 0
        self.output: Duty = 0
        # clear_faults left the driver's direction flag forwards while the duty is negative
        self.forward_flag = False
        self.last_step: Optional[PidStep] = None
        self._next_update: Optional[int] = None
        self.due = 0            # the Hat ticks the controller from this virtual ms on
        self.reset()

    # -- state ---------------------------------------------------------------------------
    def reset(self) -> None:
        """``port_initpwm`` (#fb-port-reset)."""
        self.pwmmode = MODE_PWM
        self.coast = False
        self.setpoint = 0.0
        self.generator.reset()
        self.pid.clear()
        self.pv.clear()
        self.var.clear()
        self.drive.reset(reset_limit=self.per_port_limit)

    def autopower(self) -> None:
        """R4/R6+ LED-matrix auto-power on establish (#fb-led-matrix): constant 1.0, coast cleared."""
        self.generator.set_constant(1.0)
        self.coast = False

    def motor_output(self) -> Duty:
        """What the motor terminals see: the last driver write, or ``"coast"`` while a motor
        fault is latched in this port's driver."""
        faults = getattr(self.hat, "faults", None)
        if faults is not None and faults.output_disabled(self.index):
            return COAST
        return self.output

    def clear_faults(self) -> None:
        """``clear_faults`` writes the driver's flag register (outputs on, direction forwards,
        FIRMWARE-BEHAVIOUR#fb-commands), and the firmware writes the direction again only when the
        duty changes sign: a port driven backwards goes on forwards until then. A coasting one is
        driven forwards at the coast amount (1) until the next coast write."""
        if self.duty == COAST:
            self.duty = 1              # what the driver holds now; the next update coasts it again
            self._show(1)
        elif isinstance(self.duty, int) and self.duty < 0:
            self.forward_flag = True
            self._show(-self.duty)

    # -- time ----------------------------------------------------------------------------
    @property
    def next_update_at(self) -> Optional[int]:
        """Virtual time of the next 10 ms update (None before the first tick)."""
        return self._next_update

    def start(self, now: int) -> None:
        """The main loop starts in millisecond ``now`` (the one of ``Done initialising ports``):
        the firmware's update timer counts from there, so the updates fall on ``now + 10k``
        (docs/EMULATOR-MODELS.md "Controller")."""
        self._next_update = now + PWM_UPDATE_MS
        self.due = self._next_update

    def tick(self, now: int) -> None:
        """Called every 1 ms; runs :meth:`update` every 10 ms without drift."""
        if self._next_update is None:
            self._next_update = now + PWM_UPDATE_MS     # not started by a HAT (a bare controller)
        while now >= self._next_update:
            self._next_update += PWM_UPDATE_MS
            self.update()
        self.due = self._next_update     # nothing happens in between (the Hat skips those ms)

    def update(self) -> None:
        """One 10 ms controller pass (#fb-controller, steps 1-5)."""
        sp, done = self.generator.step(self._read_var)
        self.setpoint = sp
        if done:
            self.hat.emit(f"P{self.index:X}: {done}".encode("ascii"))
        if not self._port_connected(self.index):
            self._write(0)
            return
        if self.coast:
            self._write(COAST)
            return
        if self.pwmmode == MODE_PWM:
            self._write(self.drive.drive(sp))
            return
        pv = self.pv.sample(self._mode_data(self.pv.port, self.pv.mode),
                            differentiate=self.pwmmode == MODE_PID_DIFF)
        if pv is None:
            return                  # no data yet: the previous drive level persists
        step = self.pid.step(pv, sp)
        self.last_step = step
        if self.hat.debug & 16:
            self.hat.emit(self.debug_line(step).encode("ascii"))
        self._write(self.drive.drive(step.cv))

    def debug_line(self, step: PidStep) -> str:
        """The debug-16 line (#fb-debug-pid)."""
        f = format_float
        return (f"P{self.index:X}: pv={f(step.pv)} sp={f(step.sp)}: e={f(step.e)} "
                f"ie={f(step.ie)} de={f(step.de)} cv={f(step.cv)}")

    # -- internals -----------------------------------------------------------------------
    def _read_var(self) -> float:
        # set var: the svar without differentiation; it keeps its last value without data.
        self.var.sample(self._mode_data(self.var.port, self.var.mode))
        return self.var.value

    def _write(self, duty: Duty) -> None:
        if duty != self.duty:
            self.duty = duty
            if self.forward_flag and isinstance(duty, int) and duty < 0:
                self._show(-duty)                 # the amount changes, the direction flag does not
            else:
                self.forward_flag = False
                self._show(duty)

    def _show(self, output: Duty) -> None:
        if output != self.output:
            self.output = output
            self.hat.set_drive(self.index, output)
            self.hat.ports[self.index].wake()     # the device on the port sees a new drive

    def _port_connected(self, p: int) -> bool:
        # A port object without the flag (hat.py's placeholder) counts as empty.
        return bool(getattr(self.hat.ports[p], "connected", False))

    def _mode_data(self, p: int, mode: int) -> Optional[bytes]:
        read = getattr(self.hat.ports[p], "mode_data", None)
        return read(mode) if read is not None else None
