"""The one script runner: ``script``, ``record`` and ``replay`` all run scenarios through it, and
the emulator's ``--script`` mode walks its actions with :func:`walk_actions` too (through a driver
that records what only an in-process emulator sees), so one place times a script's actions.

A scenario (a parsed script, transcripts/script.py, or a replay plan turned into one) runs on any
target through a :class:`Session`: in virtual time on a virtual-time target (``inprocess``),
in real time (x time_scale) on the rest. Every action happens at its scripted time, the sum of
the ``@wait``s before it, measured from t = 0 on the session's clock (so waits do not add up the
time each send took): host lines go to the target as their exact bytes, world actions through
the target's control. Before anything is sent the runner checks that the target can do every
world action the script uses, and that the script's start-up layout (``@device``) can be had;
if not it raises :class:`NeedsCapability` ("needs plug", "needs layout").

The transcript gets a meta line once the firmware is known (the session's ``version``
exchange at open is kept, with t < 0), then every byte as it crosses (written as it arrives,
so a killed run keeps what came), then ``end``.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from typing import IO, Dict, List, Optional, Protocol, Union

from ..harness.errors import NeedsCapability, TargetError
from ..harness.events import Event
from ..harness.session import Session
from ..harness.targets.base import Target
from ..harness.transcript import TranscriptWriter
from ..plumbing.package_version import __version__
from ..protocol.devices import DEFAULT_LAYOUT, format_device_spec
from .script import Action, Script

__all__ = ["ScriptResult", "run_script", "walk_actions", "Walk", "ActionDriver", "check_capabilities",
           "target_layout", "format_layout", "layout_meta", "TAIL_MS"]

TAIL_MS = 20            # SCENARIO-SCRIPT.md: after the last action a run continues for 20 ms
_LAYOUT_WAIT_S = 10.0   # HAT seconds for devices to connect before the live layout is judged
_LAYOUT_POLL_MS = 300   # HAT ms between two `list`s while waiting for the layout


@dataclass
class ScriptResult:
    """What a run produced. ``ok`` False carries the ``reason`` (the run stopped early)."""

    script: Script
    target: str
    firmware: str = "unknown"
    transcript_path: Optional[str] = None
    ok: bool = True
    reason: str = ""
    events: List[Event] = field(default_factory=list)
    received: bytes = b""
    notes: List[str] = field(default_factory=list)
    late_ms: float = 0.0    # how far (HAT ms) the latest action went out after its scripted time
    virtual: bool = False   # ran in the target's virtual time (deterministic, never late)


def format_layout(layout: Dict[int, Optional[tuple]]) -> str:
    return ", ".join(f"P{p} {format_device_spec(layout.get(p))}" for p in range(4))


def layout_meta(layout: Dict[int, Optional[tuple]]) -> Dict[str, str]:
    """A layout as the transcript's ``meta.devices`` holds it: ``{"0": "0x30", "2": "passive 8"}``."""
    return {str(p): format_device_spec(s) for p, s in sorted(layout.items())}


def target_layout(target: Target) -> Optional[Dict[int, Optional[tuple]]]:
    """The start-up layout a target was made with, when it says (emulators); else None."""
    layout = getattr(target, "layout", None)
    if isinstance(layout, dict):
        return dict(layout)
    devices = getattr(target, "devices", None)
    if isinstance(devices, dict):
        merged = dict(DEFAULT_LAYOUT)
        merged.update(devices)
        return merged
    return None


def check_capabilities(script: Script, target: Target, layout_on_rig: bool = False) -> None:
    """Raise NeedsCapability unless the target can perform everything the script needs.

    ``layout_on_rig``: the operator says the HAT is wired as the script's ``@device`` lines
    ask; the runner then checks it with ``list`` at open instead of needing ``layout``.
    """
    for cap in sorted(script.capabilities - {"layout"}):
        if not target.has(cap):
            raise NeedsCapability(cap, target.url, f"the script uses @{cap}; target {target.url} has no "
                                  "control that can do it (a real HAT needs a rig or an operator)")
    if not script.explicit_devices:
        return
    layout = target_layout(target)
    if target.has("layout") and layout is not None:
        wrong = {p: s for p, s in script.explicit_devices.items() if layout.get(p) != s}
        if wrong:
            raise NeedsCapability("layout", target.url,
                                  f"the script wants {format_layout(script.devices)} but the target was "
                                  f"started with {format_layout(layout)}; start it with the script's layout "
                                  "(the script command does this for emulator targets)")
        return
    if not layout_on_rig:
        raise NeedsCapability("layout", target.url,
                              f"the script sets the start-up layout ({format_layout(script.devices)}) and "
                              f"target {target.url} cannot; wire the HAT that way and say so with "
                              "--layout-on-rig, and the layout is checked with `list` before the run")


def _live_layout(session: Session, want: Dict[int, Optional[tuple]],
                 timeout_s: float) -> Dict[int, Optional[tuple]]:
    """The layout as `list` reports it, polled until it shows ``want`` or time is up
    (devices take a while to connect after power-on)."""
    deadline = time.monotonic() + timeout_s
    # HAT time bounds the polling too: a virtual-time target moves only as it is read
    polls_left = int(timeout_s * session.time_scale * 1000 / _LAYOUT_POLL_MS) + 1
    while True:
        layout: Dict[int, Optional[tuple]] = {}
        for e in session.command("list"):
            if e.is_port_status and e.port is not None:
                state, ident = e.fields.get("state"), e.fields.get("id")   # no id: state "none"
                layout[e.port] = (str(state), ident) if isinstance(ident, int) else None
        polls_left -= 1
        if all(layout.get(p) == s for p, s in want.items()) or time.monotonic() >= deadline \
                or polls_left <= 0:
            return layout
        session.wait_ms(_LAYOUT_POLL_MS)


def run_script(script: Script, target: Target, transcript: Union[str, os.PathLike, IO[str], None] = None,
               open_timeout: float = 2.0, layout_on_rig: bool = False,
               meta: Optional[dict] = None, layout_wait_s: float = _LAYOUT_WAIT_S,
               end_ms: Optional[float] = None) -> ScriptResult:
    """Run ``script`` on ``target`` (opened here, closed at the end) and write the transcript
    to ``transcript`` (a path or an open text file; None: no transcript). Raises
    NeedsCapability before anything is sent and TargetError if the target cannot be opened; a
    failure during the run ends it early with ``ok=False`` and the transcript holds every byte
    received until then. ``layout_wait_s``: HAT seconds allowed for the start-up devices to
    appear in `list`. ``end_ms``: the scripted time the run lasts until (default: 20 ms after
    the last action, as the format says; a replay passes the recording's end)."""
    check_capabilities(script, target, layout_on_rig)
    path = os.fspath(transcript) if isinstance(transcript, (str, os.PathLike)) else None
    result = ScriptResult(script=script, target=target.url, transcript_path=path)
    session = Session(target)
    result.virtual = session.virtual
    writer: Optional[TranscriptWriter] = None
    try:
        if session.virtual:
            # A virtual-time target opens to the same state every time: one opening answers
            # `version` and shows its layout, the next one runs the script from its start.
            probe = Session(target)
            try:
                _open_and_wait_for_layout(probe, script, result, open_timeout, layout_on_rig, layout_wait_s)
            finally:
                probe.close()
            _open_at_start(session)
            session.profile = probe.profile
        else:
            _open_and_wait_for_layout(session, script, result, open_timeout, layout_on_rig, layout_wait_s)
        session.set_origin()
        if transcript is not None:
            writer = TranscriptWriter(transcript, _meta(script, target, session, result, meta))
            for note in session.notes + result.notes:
                writer.note(session.transcript_now(), note)
            session.attach_transcript(writer)
            # Writing the history took a moment: restart the clock so the first action is at
            # t = 0 (start-up times shift by those few ms, which nothing depends on).
            session.set_origin()
        start = len(session.events)
        _run_actions(script, session, result, end_ms)
        result.events = session.events[start:]
        result.notes.extend(n for n in session.notes if n not in result.notes)
    finally:
        t_end = session.transcript_now()
        result.received = bytes(session.received)
        session.close()
        if writer is not None:
            writer.close(t_end)
    return result


def _open_at_start(session: Session) -> None:
    """A virtual-time target opens where the emulator's script mode starts a script: at the
    moment the layout is established (InProcessTarget boots to it). Nothing is sent before
    t = 0, so device timers keep the phase they have in script mode and a replay of its
    transcripts is exact."""
    session.open(detect=False)
    session.poll()   # the start-up output, kept before t = 0


def _open_and_wait_for_layout(session: Session, script: Script, result: ScriptResult, open_timeout: float,
                              layout_on_rig: bool, layout_wait_s: float) -> None:
    """Open a real-time target with the session's ``version`` exchange (kept at t < 0), then
    wait for the start-up layout where the target or the operator says there is one."""
    target = session.target
    session.open(timeout=open_timeout)
    result.firmware = session.version_string or "unknown"
    if session.in_bootloader:
        result.notes.append("the target answered from its bootloader")
    if target.has("layout") and not session.in_bootloader:
        # Like the emulator's script mode, start once the devices are established (the
        # real-time emulator is still connecting them when it first answers).
        live = _live_layout(session, script.devices, layout_wait_s / session.time_scale)
        if any(live.get(p) != s for p, s in script.devices.items()):
            raise TargetError(f"{target.url} did not bring up the script's layout within "
                              f"{layout_wait_s:g} s: `list` shows {format_layout(live)}, the script "
                              f"wants {format_layout(script.devices)}")
    elif layout_on_rig and script.explicit_devices:
        live = _live_layout(session, script.explicit_devices, layout_wait_s / session.time_scale)
        if any(live.get(p) != s for p, s in script.explicit_devices.items()):
            raise NeedsCapability("layout", target.url,
                                  f"`list` shows {format_layout(live)}, the script wants "
                                  f"{format_layout(script.devices)}")
    session.drain(quiet=0.05, limit=0.5)


class ActionDriver(Protocol):
    """What :func:`walk_actions` needs of whatever runs the script: a session on a target here, the
    emulator's script mode (emulator/script_mode.py) where only an in-process emulator can
    record its own events. Times are HAT ms since t = 0."""

    def now(self) -> float: ...
    def wait_until(self, t_ms: float) -> None: ...
    def send(self, data: bytes) -> None: ...
    def world(self, text: str) -> None: ...


@dataclass
class Walk:
    """Where a walk is (for the message of a run that stops early) and how late it went."""

    where: str = "before the first action"
    action: Optional[Action] = None
    late_ms: float = 0.0


def walk_actions(script: Script, driver: ActionDriver, end_ms: Optional[float] = None,
                 walk: Optional[Walk] = None) -> Walk:
    """The one walk over a script: each action at its scripted time (the sum of the ``@wait``s before
    it), then on until ``end_ms`` or TAIL_MS after the scripted end, whichever is later. ``walk``
    is updated as it goes, so a caller whose driver raised knows where."""
    walk = walk if walk is not None else Walk()
    scripted = 0.0
    for action in script.actions:
        if action.kind == "wait":
            scripted += action.args[0]
            continue
        walk.action = action
        walk.where = f"at line {action.lineno} ({action.text.strip()})" if action.lineno \
            else f"at t={scripted:g} ms ({action.text.strip()})"
        driver.wait_until(scripted)
        walk.late_ms = max(walk.late_ms, driver.now() - scripted)
        if action.kind == "send":
            driver.send(action.data)
        else:
            driver.world(action.text.strip())
    walk.action, walk.where = None, "after the last action"
    driver.wait_until(max(scripted + TAIL_MS, end_ms or 0.0))
    return walk


class _SessionDriver:
    """A session as the walk's driver: waits on the session's clock (HAT time), world actions
    through the target's control."""

    def __init__(self, session: Session):
        self.session = session

    def now(self) -> float:
        return self.session.transcript_now()

    def wait_until(self, t_ms: float) -> None:
        left = t_ms - self.session.transcript_now()
        if left > 0:
            self.session.wait_ms(left)

    def send(self, data: bytes) -> None:
        self.session.send_raw(data)
        self.session.poll()   # a virtual-time target's answer in the same millisecond, in order

    def world(self, text: str) -> None:
        self.session.world(text)
        self.session.poll()


def _run_actions(script: Script, session: Session, result: ScriptResult, end_ms: Optional[float]) -> None:
    """The script's actions on the session; a target failure stops the run with where it happened."""
    walk = Walk()
    try:
        walk_actions(script, _SessionDriver(session), end_ms, walk)
        if not session.virtual:
            # On a sped-up target 20 HAT-ms are a few wall-ms, shorter than the link's own
            # latency: also wait for the answers already on their way to go quiet.
            session.drain(quiet=0.05, limit=0.5)
    except (TargetError, OSError) as exc:
        result.ok, result.reason = False, f"stopped {walk.where}: {exc}"
    finally:
        result.late_ms = walk.late_ms


def _meta(script: Script, target: Target, session: Session, result: ScriptResult,
          extra: Optional[dict]) -> dict:
    info = {"firmware": result.firmware, "target": target.url, "script": script.source,
            "name": script.name, "devices": layout_meta(script.devices),
            "tool": f"buildhat-conformance {__version__} script", "time_scale": session.time_scale}
    if session.profile is not None:
        info["profile"] = session.profile.name
    if session.in_bootloader:
        info["bootloader"] = True
    info.update(extra or {})
    return info
