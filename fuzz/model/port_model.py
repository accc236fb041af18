"""The reference model's view of one port, written from docs/FIRMWARE-BEHAVIOUR.md (#fb-async,
#fb-data, #fb-controller, #fb-device-messages): its selection and
combi table (which reports it may print, in which form), the drive settings (the duty it settles
at), and what a device connecting or finishing its setup does to them. The parser that changes
this state is :class:`~.model.ReferenceModel`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, FrozenSet, Optional, Sequence, Tuple, Union

from ...protocol.profiles import Profile
from .line_parsing import f32

__all__ = ["PortModel", "expected_duty", "established", "mode_count", "UNKNOWN_Q16", "PWMMODE_UNKNOWN"]

# A drive setting an earlier run may have left on a kept-open HAT (PortModel.forget_drive): no Q16
# value a command can store, and no controller mode.
UNKNOWN_Q16 = -(1 << 48)
PWMMODE_UNKNOWN = -1
DEFAULT_PLIMIT = 6554                  # 0.1 in Q16: a port's limit after a port reset (R6+)


@dataclass
class PortModel:
    mode: int = -1                # selected mode, -1 = none
    var: bool = False             # the `select <m> <off> <fmt>` form (prints P<p>V:)
    once: bool = False            # R1-R4 once flag (selonce)
    rate: int = -2                # R5+: -2 off, -1 once, 0 every message, N ms
    selection: int = 0            # which select/selonce made it (a report ends only its own once)
    offset: int = 0
    combi: Dict[int, int] = field(default_factory=dict)   # index -> number of recorded pairs
    # Indices whose entry the model has not seen set: a HAT kept open from an earlier run keeps
    # its combi table through the prelude (only a new connection clears it, fb-combi).
    combi_unknown: FrozenSet[int] = frozenset()
    known: bool = True            # False after an event the model cannot follow exactly
    pwmmode: int = 0              # 0 direct PWM, 1 PID, 2 PID on the derivative
    coast: bool = False
    plimit: int = DEFAULT_PLIMIT  # R6+ per-port limit (Q16); reset with the port (fb-port-reset)
    constant: Optional[float] = None  # the constant setpoint, when the generator holds one we know
    bias: int = 0                 # R1-R5 bias (Q16)
    pwmparams: Tuple[int, int] = (0, 0)   # R6+ (pwmthresh, minpwm), Q16
    device_modes: int = 0         # modes of the established active device here (0: none or unknown)
    tampered: bool = False        # write1/write2/combi reached the device: its mode is not ours to know
    # clear_faults flags every driver forwards and the firmware writes the direction only when the duty
    # changes sign (fb-commands, `clear_faults`): a negative duty may show as its opposite until a
    # steady drive shows it is not.
    forward_flag: bool = False

    def copy(self) -> PortModel:
        """An independent copy: every field is immutable except ``combi`` (a dict of ints).
        Much cheaper than ``dataclasses.replace``/``deepcopy``; the runner copies every port
        before and after every input."""
        fields = self.__dict__.copy()
        fields["combi"] = self.combi.copy()
        dup = object.__new__(type(self))
        dup.__dict__ = fields
        return dup

    def reporting(self, selrate_engine: bool) -> bool:
        if not 0 <= self.mode <= 7:     # modes 8..15 never report (fb-high-modes)
            return False
        return self.rate != -2 if selrate_engine else True

    def report_forms(self) -> Tuple[str, ...]:
        """The data line this selection prints: ``V``, ``C<i>`` or ``M<m>`` (fb-data-lines); both ``C<m>``
        and ``M<m>`` when the combi entry of the mode is not known."""
        if self.var:
            return ("V",)
        if self.combi.get(self.mode, 0) > 0:
            return (f"C{self.mode}",)
        if self.mode in self.combi_unknown:
            return (f"C{self.mode}", f"M{self.mode}")
        return (f"M{self.mode}",)

    def forget_drive(self, commands: Sequence[str]) -> None:
        """The drive settings may hold anything (a run on a HAT an earlier run left): the prelude
        resets none of them, so the duty is not judged until this run sets each one again. Only
        those the release's ``commands`` can set (`bias` R1-R5, `pwmparams` R6+)."""
        self.pwmmode = PWMMODE_UNKNOWN
        if "bias" in commands:
            self.bias = UNKNOWN_Q16
        if "pwmparams" in commands:
            self.pwmparams = (UNKNOWN_Q16, UNKNOWN_Q16)
        self.plimit = UNKNOWN_Q16
        self.forward_flag = True          # (a clear_faults then may have flagged it forwards)

    def forget_combis(self) -> None:
        """The combi table may hold anything (a run on a HAT an earlier run left)."""
        self.combi.clear()
        self.combi_unknown = frozenset(range(8))

    def clear_combis(self) -> None:
        """The combi table is empty (a new connection)."""
        self.combi.clear()
        self.combi_unknown = frozenset()

    def link_changed(self, type_id: Optional[int] = None) -> None:
        """A device connected, went away or failed (fb-async): the select state resets (the model no
        longer knows it) and the port reset (fb-port-reset) drops the setpoint; short of ``established``,
        it also puts the controller, bias, pwmparams and limit back to their defaults. ``type_id``: a device
        with this type id finished its setup (``established``)."""
        self.known = False
        self.constant = None
        if type_id is None:
            self.device_modes = 0
            self.clear_combis()     # a new connection clears the table (fb-combi); none reports before it
            # The port reset (fb-port-reset): what a disconnect, or a scan of an empty port, puts back.
            self.pwmmode, self.coast, self.bias, self.pwmparams = 0, False, 0, (0, 0)
            self.plimit = DEFAULT_PLIMIT
        else:
            established(self, type_id)


def expected_duty(profile: Profile, p: PortModel, global_plimit: int) -> Optional[Union[int, str]]:
    """The motor-driver duty (±255, or "coast") a port in direct-PWM mode settles at (fb-pwm-path), or
    None when the model does not know it (PID, a waveform, bias or pwmparams in play)."""
    if p.coast:
        return "coast"
    if p.pwmmode != 0 or p.constant is None or p.bias or p.pwmparams != (0, 0):
        return None                    # (an unknown mode, bias or pwmparams: these too)
    x = min(max(p.constant, -1.0), 1.0)
    t = int(f32(x * 131072.0))                 # trunc toward zero
    u = int((t + 1) / 2)                       # C integer division: toward zero
    limit = p.plimit if profile.feature("plimit_scope") == "per_port" else global_plimit
    if limit == UNKNOWN_Q16:
        return None
    v = min(max(u, -limit), limit)
    return (v * 255 + 127) >> 16               # arithmetic shift: floor


def mode_count(type_id: int) -> int:
    """How many modes an active device has (the device catalogue); 0 if it is not catalogued."""
    from ...protocol.devices import active_device
    try:
        return int(active_device(type_id).get("mode_count", 0))
    except KeyError:
        return 0


def established(p: PortModel, type_id: int) -> None:
    """An active device finished its setup on this port (fb-active). The connection cleared the combi
    table when it began; the facts do not say whether an entry set during the setup survives
    (the HAT keeps it in the slot of mode i's description, which the setup fills: fb-combi), so those
    entries, and any the model did not see the connection begin after, are unknown."""
    p.device_modes = mode_count(type_id)
    p.tampered = False
    p.combi_unknown = p.combi_unknown | frozenset(p.combi)
    p.combi.clear()
