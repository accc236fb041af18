"""Script mode: run a scenario script (docs/formats/SCENARIO-SCRIPT.md) in virtual time and
write its transcript (docs/formats/TRANSCRIPT.md).

The start-up runs before the script and is recorded at t < 0: the banner and the layout's
devices connecting. t = 0 is the moment every device of the layout is established. Host
bytes are handled in the millisecond they are sent, world actions happen at once, and the
run ends 20 ms after the last action. Nothing depends on the wall clock, so the same script
gives the same bytes every time.
"""
from __future__ import annotations

import math
from typing import IO, Any, Dict, List, Optional, Tuple

from ...harness.transcript import TranscriptWriter
from ...protocol.devices import format_device_spec
from ...transcripts.script import Script
from ..api import Emulator
from ..world import WorldError

__all__ = ["run_script", "TAIL_MS", "ScriptRunError"]

TAIL_MS = 20


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


def run_script(script: Script, out: IO[str], *, firmware: Any = None,
               devices: Optional[Dict[int, Optional[tuple]]] = None, version_string: Optional[str] = None,
               seed: int = 0, baud: Optional[int] = None, lint: Any = None,
               tool_version: str = "", lint_notes: bool = False) -> int:
    """Run ``script``, writing the transcript JSONL to ``out`` (with ``lint_notes``, each host-lint
    finding as a ``note`` event too). Returns the exit status."""
    layout = dict(script.devices)
    layout.update(devices or {})
    emu = Emulator(firmware=firmware, devices=layout, version_string=version_string, seed=seed, baud=baud)
    if lint is not None:
        lint.follow(emu)
    rec = _Recorder(emu)
    rec.pump()
    emu.boot(each_ms=rec.pump)
    emu.step()                      # one more ms, so all start-up output is at t < 0
    rec.pump()
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
    target = 0.0                                 # scripted time (ms since t = 0)

    def run_until(ms: float) -> None:
        while emu.now - prelude < math.ceil(ms - 1e-9):
            emu.step()
            rec.pump()
            if lint is not None:
                lint.follow(emu)

    for action in script.actions:
        if action.kind == "wait":
            target += action.args[0]
            run_until(target)
        elif action.kind == "send":
            rec.pump()
            writer.flush_partial()           # a prompt keeps the time it was printed
            writer.host(emu.now - prelude, action.data)
            if lint is not None:
                lint.feed_input(action.data)
            emu.write(action.data)
            rec.pump()
        else:
            try:
                emu.world(action.text)
            except WorldError as exc:
                writer.end(emu.now - prelude)
                raise ScriptRunError(f"{script.source}:{action.lineno}: {exc}") from None
            rec.pump()
    run_until(emu.now - prelude + TAIL_MS)
    rec.pump()
    writer.end(emu.now - prelude)
    return 0
