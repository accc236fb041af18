"""Script mode: run a scenario script (docs/formats/SCENARIO-SCRIPT.md) in virtual time and
write its transcript (docs/formats/TRANSCRIPT.md). The one script runner's walk
(transcripts/script_runner.py ``walk_actions``) times the actions; this module is its driver for an
in-process emulator, which records what only it can see (device frames, drive and LED events).

The start-up runs before the script and is recorded at t < 0: the banner and the layout's
devices connecting. t = 0 is the moment every device of the layout is established. Host
bytes are handled in the millisecond they are sent, world actions happen at once, and the
run ends 20 ms after the last action. Nothing depends on the wall clock, so the same script
gives the same bytes every time.
"""
from __future__ import annotations

import math
from typing import IO, Any, Dict, List, Optional, Tuple

from ..harness.transcript import TranscriptWriter
from ..protocol.devices import format_device_spec
from ..transcripts.script import Script
from ..transcripts.script_runner import Walk, walk_actions
from .api import Emulator
from .world_actions import WorldError

__all__ = ["run_script", "ScriptRunError"]


class ScriptRunError(RuntimeError):
    """A script action the emulator could not perform (the message names the line)."""


class _Recorder:
    """Collects output and events with absolute times, then writes them relative to t0."""

    def __init__(self, emu: Emulator):
        self.emu = emu
        self.writer: Optional[TranscriptWriter] = None
        self.t0 = 0
        self.backlog: List[Tuple[int, str, Any]] = []
        emu.on_event(self._event)

    def _event(self, event: Dict[str, Any]) -> None:
        self.pump()                   # output written before the event comes first
        fields = {k: v for k, v in event.items() if k not in ("t", "dir")}
        self._put(event["t"], event["dir"], fields)

    def pump(self) -> None:
        data = self.emu.read()
        if data:
            self._put(self.emu.now, "hat", data)

    def _put(self, t: int, kind: str, payload: Any) -> None:
        if self.writer is None:
            self.backlog.append((t, kind, payload))
        else:
            self._write(t, kind, payload)

    def _write(self, t: int, kind: str, payload: Any) -> None:
        writer = self.writer
        assert writer is not None            # _put keeps a backlog until start()
        rel = t - self.t0
        if kind == "hat":
            writer.hat(rel, payload)
        elif kind == "host":
            writer.host(rel, payload)
        else:
            writer.flush_partial()           # keep the file in time order
            writer.event(kind, rel, **payload)

    def start(self, writer: TranscriptWriter, t0: int) -> None:
        self.writer, self.t0 = writer, t0
        for item in self.backlog:
            self._write(*item)
        self.backlog.clear()


class _ScriptModeDriver:
    """The in-process emulator as the one runner's driver (transcripts/script_runner.py): every
    millisecond stepped and pumped into the recorder (output before the events it caused), host
    bytes written into the transcript as they go in, and the lint fed with them."""

    def __init__(self, emu: Emulator, rec: _Recorder, writer: TranscriptWriter, prelude: int, lint: Any):
        self.emu, self.rec, self.writer, self.prelude, self.lint = emu, rec, writer, prelude, lint

    def now(self) -> float:
        return self.emu.now - self.prelude

    def wait_until(self, t_ms: float) -> None:
        while self.emu.now - self.prelude < math.ceil(t_ms - 1e-9):
            self.emu.step()
            self.rec.pump()
            if self.lint is not None:
                self.lint.follow(self.emu)

    def send(self, data: bytes) -> None:
        self.rec.pump()
        self.writer.flush_partial()           # a prompt keeps the time it was printed
        self.writer.host(self.emu.now - self.prelude, data)
        if self.lint is not None:
            self.lint.feed_input(data)
        self.emu.write(data)
        self.rec.pump()

    def world(self, text: str) -> None:
        self.emu.world(text)
        self.rec.pump()


def run_script(script: Script, out: IO[str], *, firmware: Any = None,
               devices: Optional[Dict[int, Optional[tuple]]] = None, version_string: Optional[str] = None,
               seed: int = 0, baud: Optional[int] = None, lint: Any = None,
               tool_version: str = "", lint_notes: bool = False, fast_setup: bool = False) -> int:
    """Run ``script``, writing the transcript JSONL to ``out`` (with ``lint_notes``, each host-lint
    finding as a ``note`` event too). Returns the exit status."""
    layout = dict(script.devices)
    layout.update(devices or {})
    emu = Emulator(firmware=firmware, devices=layout, version_string=version_string, seed=seed, baud=baud,
                   fast_setup=fast_setup)
    if lint is not None:
        lint.follow(emu)
    rec = _Recorder(emu)
    rec.pump()
    emu.boot(each_ms=rec.pump)      # scenario time 0 is where the boot ends, as on every target
    prelude = emu.now
    hat = emu.hat
    assert hat is not None          # built without the bootloader: the firmware runs
    meta = {
        "firmware": hat.version_string, "profile": emu.profile.name,
        "target": "emulator", "script": script.source, "name": script.name,
        "devices": {str(p): format_device_spec(s) for p, s in sorted(layout.items())},
        "prelude_ms": prelude, "tool": "buildhat-emulator", "version": tool_version,
    }
    if baud:
        meta["baud"] = baud
    writer = TranscriptWriter(out, meta)
    rec.start(writer, prelude)
    if lint is not None and lint_notes:
        def lint_note(finding: Any) -> None:
            writer.flush_partial()
            writer.note(emu.now - prelude, f"host lint: {finding.describe()}")
        lint.on_finding.append(lint_note)
    walk = Walk()
    try:
        walk_actions(script, _ScriptModeDriver(emu, rec, writer, prelude, lint), walk=walk)
    except WorldError as exc:
        writer.end(emu.now - prelude)
        lineno = walk.action.lineno if walk.action is not None else 0
        raise ScriptRunError(f"{script.source}:{lineno}: {exc}") from None
    rec.pump()
    writer.end(emu.now - prelude)
    return 0
