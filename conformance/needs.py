"""What a test needs around the HAT: a device on some port, a free port, a fault, sensor data.

On a target with a control channel (the emulator) the need is met through world actions
(``@plug 3 0x3E``); on a real HAT the suite looks for a port that already has the device
(from ``list``), asks the person at the bench with ``--operator``, or skips with a reason
that says exactly what to connect. Devices stay where the last test needed them (each test
states its own needs); everything changed is put back at the end of the run.
"""
from __future__ import annotations

import re
from typing import Any, Dict, List, Optional, Tuple

import pytest

from ..protocol.devices import active_device, format_device_spec, passive_device
from . import operator_prompt
from .oracles.listing import PortEntry, parse_list

__all__ = ["PortNeeds", "device_name", "missing_text"]

Spec = Optional[Tuple[str, int]]          # ("active", 0x30) / ("passive", 8) / None

# Setup of an active device takes ~1 s of HAT time; a passive ID needs 6 scans (~0.6 s).
CONNECT_MS = 6000
SETTLE_MS = 3000
STEP_MS = 250        # look at `list` at least this often while waiting for a port to change


def device_name(spec: Spec) -> str:
    if spec is None:
        return "nothing"
    kind, ident = spec
    if kind == "active":
        return f"{active_device(ident)['name']} (active ID 0x{ident:02X})"
    return f"{passive_device(ident).get('name', 'passive device')} (passive ID {ident})"


_ORDINALS = ("a", "a second", "a third", "a fourth")


def missing_text(spec: Spec, have: List[int]) -> str:
    """The skip reason for a device nobody can connect: exactly what is missing, given the
    ports that already have one the test cannot use (``have``: it needs another)."""
    if spec is None:
        return "needs an empty port: every port has a device; unplug one and run again (or use --operator)"
    name = device_name(spec)
    if not have:
        return f"needs a {name}: connect one to any port and run again (or use --operator)"
    ports = ", ".join(str(p) for p in have)
    return (f"needs {_ORDINALS[min(len(have), 3)]} {name} (port {ports} has one already): connect another "
            "to a free port and run again (or use --operator)")


class PortNeeds:
    def __init__(self, hat: Any, config: Any, original: Optional[Dict[int, Spec]] = None):
        self.hat = hat
        self.config = config
        self.operator = bool(config.getoption("operator"))
        # What each changed port had before the run changed it. Shared by the whole run: the
        # next test's needs decide the layout, and everything is put back once, at the end
        # (H10: putting each test's devices back cost about a second of set-up per plug).
        self._original: Dict[int, Spec] = {} if original is None else original

    # -- what is there -------------------------------------------------------------------
    def layout(self) -> List[PortEntry]:
        """What ``list`` shows on each port. On R1 a passive port reads as empty during each
        ~80 ms scan (docs/FIRMWARE-BEHAVIOUR.md#fb-r1-passive), so there a few looks are merged: a
        device seen once is there."""
        entries = self._one_layout()
        # An unknown build between R1 and R2 may do either: the merged looks suit both.
        key = "passive_port_reset_each_scan"
        if self.hat.undecided(key) is None and not self.hat.feature(key):
            return entries
        for _ in range(3):
            self.hat.wait_ms(70)
            for again in self._one_layout():
                if entries[again.port].kind == "empty" and again.kind == "passive":
                    entries[again.port] = again
        return entries

    def _one_layout(self) -> List[PortEntry]:
        # A device connecting meanwhile prints its own block next to the dump: look again.
        for _attempt in range(5):
            reply = self.hat.exchange("list", timeout_ms=3000)
            try:
                return parse_list(reply.list_lines())
            except ValueError:
                self.hat.wait_ms(300)
        return parse_list(self.hat.exchange("list", timeout_ms=3000).list_lines())

    @staticmethod
    def spec_of(entry: PortEntry) -> Spec:
        return None if entry.id is None else (entry.kind, entry.id)    # no ID: "empty"

    def settled_entry(self, port: int, spec: Spec, attempts: int = 8) -> PortEntry:
        """The port's ``list`` entry once it shows ``spec``; R1 shows a passive port as empty
        during each ~80 ms scan (docs/FIRMWARE-BEHAVIOUR.md#fb-r1-passive), so a few looks may be
        needed."""
        entry = self.layout()[port]
        for _ in range(attempts - 1):
            if self.spec_of(entry) == spec:
                break
            self.hat.wait_ms(40)
            entry = self.layout()[port]
        return entry

    def find(self, spec: Spec) -> Optional[int]:
        for entry in self.layout():
            if self.spec_of(entry) == spec:
                return entry.port
        return None

    # -- needs ---------------------------------------------------------------------------
    def active(self, type_id: int, avoid: Tuple[int, ...] = ()) -> int:
        """A port with this active device established (plugged on demand)."""
        return self._need(("active", type_id), avoid)

    def passive(self, ident: int, avoid: Tuple[int, ...] = ()) -> int:
        return self._need(("passive", ident), avoid)

    def empty_port(self, avoid: Tuple[int, ...] = ()) -> int:
        return self._need(None, avoid)

    def _need(self, spec: Spec, avoid: Tuple[int, ...]) -> int:
        layout = self.layout()
        if not self.can("plug") and not self.hat.devices_settled and \
                not any(self.spec_of(e) == spec and e.port not in avoid for e in layout):
            # Without a control channel the device cannot be plugged on demand; it may still
            # be setting up (about a second after power-up, docs/FIRMWARE-BEHAVIOUR.md#fb-timing):
            # look once more. Once per run (and again after a restart): what is not there then is
            # not coming.
            self.hat.wait_ms(SETTLE_MS)
            self.hat.devices_settled = True
            layout = self.layout()
        for entry in layout:
            if self.spec_of(entry) == spec and entry.port not in avoid:
                return entry.port
        # Replace the least useful port: an empty one first, then the highest number.
        candidates = [e for e in layout if e.port not in avoid]
        candidates.sort(key=lambda e: (e.kind != "empty", -e.port))
        port = candidates[0].port
        self.plug(port, spec, missing=missing_text(spec, [e.port for e in layout
                                                          if self.spec_of(e) == spec and e.port in avoid]))
        return port

    # -- what only the world sees -------------------------------------------------------
    def _inner(self) -> Any:
        target = self.hat.target
        return getattr(target, "inner", target)     # under the suite's transcript tee

    def drive_levels(self, port: int, hat_ms: float) -> List[Tuple[int, Any]]:
        """The motor drive of ``port`` during the next ``hat_ms``: (HAT ms, duty ±255 or
        "coast") for the level at the start and every change. Hardware does not print the drive;
        a target whose world sees it (``drive_events``) shows it."""
        self.require("drive_events", "seeing the motor drive a port puts out (drive levels and direction)")
        inner = self._inner()
        start = int(inner.now)
        self.hat.wait_ms(hat_ms)
        end = int(inner.now)
        # A served HAT (the emulator or the firmware on a pty) answers over its control channel.
        since = getattr(inner, "drive_events_since", None)
        events = since(start) if since is not None else list(inner.drive_events)
        changes = [(int(e["t"]), e.get("value")) for e in events
                   if e.get("dir") == "pwm" and int(e.get("port", -1)) == port]
        before = [c for c in changes if c[0] <= start]
        level = [(start, before[-1][1] if before else 0)]
        return level + [c for c in changes if start < c[0] <= end] + [(end, None)]

    def frames_to_device(self, port: int, line: str, settle_ms: float = 50.0) -> Tuple[Any, List[bytes]]:
        """``line``'s reply, and the frames the device on ``port`` received from it (within
        ``settle_ms`` after: a 131-byte frame takes 12 ms at 115200 baud). A HAT does not print
        them; a target whose world sees them (``device_frames``: inprocess, sil) shows them."""
        self.require("device_frames", "seeing the messages a device on a port receives")
        inner = self._inner()
        # A served HAT (the emulator or the firmware on a pty) answers over its control channel.
        since = getattr(inner, "device_frames_since", None)
        start = int(inner.now) if since is not None else len(inner.device_frames)
        reply = self.hat.exchange(line)
        self.hat.wait_ms(settle_ms)
        events = since(start) if since is not None else inner.device_frames[start:]
        return reply, [bytes.fromhex(e["hex"]) for e in events if int(e.get("port", -1)) == port]

    # -- changing the world --------------------------------------------------------------
    def can(self, capability: str) -> bool:
        return self.hat.can(capability)

    def require(self, capability: str, what: str) -> None:
        """Skip (saying what is missing) unless the target can perform this world action."""
        if not self.can(capability):
            pytest.skip(f"needs {what}: target {self.hat.url} has no '{capability}' control "
                        f"(use the emulator, or a rig that provides it)")

    def action(self, line: str) -> str:
        name = line.split()[0].lstrip("@")
        if self.can(name):
            return self.hat.world(line)
        pytest.skip(f"needs the world action '{line}' (target {self.hat.url} cannot perform it)")
        return ""

    def plug(self, port: int, spec: Spec, missing: Optional[str] = None) -> None:
        """Put ``spec`` on ``port`` (None: leave it empty) and wait until the HAT agrees.
        ``missing``: what a skip says is missing when nobody can do it (default: ``spec``)."""
        current = {e.port: self.spec_of(e) for e in self.layout()}
        if current.get(port) == spec:
            return
        self._original.setdefault(port, current.get(port))
        if self.can("plug"):
            if current.get(port) is not None:
                self.hat.world(f"@unplug {port}")
                self._power_if_needed(port, None)
                self._wait_for(port, None)
            if spec is not None:
                self.hat.world(f"@plug {port} {format_device_spec(spec)}")
                self._power_if_needed(port, spec)
                self._wait_for(port, spec)
            return
        if self.operator:
            what = (f"unplug whatever is on port {port}" if spec is None else
                    f"connect a {device_name(spec)} to port {port} (and nothing else there)")
            if operator_prompt.ask(self.config, what):
                self._wait_for(port, spec)
                return
        pytest.skip(missing or missing_text(spec, []))

    def _power_if_needed(self, port: int, spec: Spec) -> None:
        """Devices that disconnect without motor power soon after setup (the light matrix,
        document Appendix A) get the set-point the catalogue gives, as a host library would."""
        powered = tuple(p for p in self.hat.powered_ports if p != port)
        self.hat.powered_ports = powered
        if spec is None or spec[0] != "active":
            return
        power = active_device(spec[1]).get("power") or {}
        if not power.get("needs_port_power_at_connect") or "disconnect" not in power.get("note", ""):
            return
        self.hat.expect(lambda e: e.text == f"P{port}: established serial communication with active ID "
                        f"{spec[1]:02X}", CONNECT_MS)
        setpoint = power.get("hat_setpoint_used_by_library", 1)
        self.hat.setup(f"port {port} ; plimit 1 ; set {setpoint} ; port 0")
        self.hat.powered_ports = powered + (port,)

    def plug_only(self, port: int, spec: Spec) -> None:
        """The world action alone, for tests that watch what plugging prints: no ``list``
        before or after (its output would mix with the connect messages). Restored as usual."""
        self.require("plug", "plugging devices in and out")
        current = {e.port: self.spec_of(e) for e in self.layout()}
        self._original.setdefault(port, current.get(port))
        if spec is None:
            self.hat.world(f"@unplug {port}")
        else:
            self.hat.world(f"@plug {port} {format_device_spec(spec)}")

    def unplug(self, port: int) -> None:
        self.plug(port, None)

    def replug(self, port: int) -> bool:
        """Plug the device on ``port`` in again, where the world can: the HAT resets the port
        (docs/FIRMWARE-BEHAVIOUR.md#fb-port-reset) and the device starts afresh, so nothing an
        earlier case left there (a preset position, an unwrapped PV) remains. False: it cannot."""
        if not self.can("plug"):
            return False
        spec = self.spec_of(self.layout()[port])
        self.plug(port, None)
        self.plug(port, spec)
        return True

    def _wait_for(self, port: int, spec: Spec) -> None:
        """Until ``list`` shows ``spec`` on the port. ``list`` is asked again when the HAT prints
        a line that ends a change on that port (docs/FIRMWARE-BEHAVIOUR.md#fb-async), or after
        ``STEP_MS`` without one
        (R1 prints nothing when a passive device goes)."""
        ends_change = re.compile(rf"P{port}: (?:established serial|connected to passive|disconnected|"
                                 rf"timeout|too many errors|checksum error)")
        began = self.hat.mark()
        look_from = began
        waited = 0.0
        entries: Dict[int, Spec] = {}
        while waited <= CONNECT_MS:
            if spec is not None and spec[0] == "passive" and any(
                    e.text == f"P{port}: connected to passive ID {spec[1]}" for e in self.hat.since(began)):
                # R1 shows a rescanned passive port as empty most of the time
                # (docs/FIRMWARE-BEHAVIOUR.md#fb-r1-passive).
                return
            t0 = self.hat.clock()
            self.hat.watch(look_from, lambda e: bool(ends_change.match(e.text)), STEP_MS)
            look_from = self.hat.mark()
            waited += max((self.hat.clock() - t0) * 1000.0 * self.hat.time_scale, 1.0)
            entries = {e.port: self.spec_of(e) for e in self.layout()}
            if entries.get(port) == spec:
                return
        raise AssertionError(f"port {port} did not become {device_name(spec)} within {CONNECT_MS} ms "
                             f"of HAT time (list shows {device_name(entries.get(port))})")

    def restore(self) -> None:
        """Put every port changed during the run back as it was."""
        original = dict(self._original)
        self._original.clear()
        for port, spec in sorted(original.items()):
            try:
                self.plug(port, spec)
            except BaseException:  # noqa: B036 - a skip/failure here must not hide the verdicts
                pass
        self._original.clear()
