"""``--transcript FILE`` for the real-time modes: every byte both ways, the device-side events and the
host-lint findings, in the project's JSONL transcript format (harness/transcript.py writes it).

Times are the emulator's virtual milliseconds since the link opened (t = 0); with ``--booted`` the
start-up ran before and is not in the file (its output reached no host). Every event is flushed as it
is written, so a killed emulator leaves a transcript that is complete up to its last millisecond.
"""
from __future__ import annotations

from typing import Any, Dict, Optional

from ...harness.transcript import TranscriptWriter

__all__ = ["LinkRecorder"]


class LinkRecorder:
    """The ``tap`` of ``run_realtime``: ``host(data)`` / ``hat(data)``, plus the emulator's events and
    the lint's findings (as ``note`` events) once :meth:`attach` has run."""

    def __init__(self, path: str, emulator: Any, meta: Dict[str, Any]):
        self.emulator = emulator
        self.t0 = emulator.now
        head = dict(meta)
        hat = emulator.hat
        head.setdefault("firmware", hat.version_string if hat is not None else "bootloader")
        self.writer = TranscriptWriter(path, head)
        self.path = path

    def _t(self) -> int:
        return self.emulator.now - self.t0

    def attach(self, lint: Any = None) -> LinkRecorder:
        """Record the emulator's device-side events and, with ``lint``, its findings."""
        self.emulator.on_event(self._event)
        if lint is not None:
            lint.on_finding.append(self._finding)
        return self

    def host(self, data: bytes) -> None:
        self.writer.host(self._t(), data)

    def hat(self, data: bytes) -> None:
        self.writer.hat(self._t(), data)

    def _event(self, event: Dict[str, Any]) -> None:
        fields = {k: v for k, v in event.items() if k not in ("t", "dir")}
        self.writer.flush_partial()              # keep the file in time order
        self.writer.event(event["dir"], event["t"] - self.t0, **fields)

    def _finding(self, finding: Any) -> None:
        self.writer.flush_partial()
        self.writer.note(self._t(), f"host lint: {finding.describe()}")

    def close(self, exit_status: Optional[int] = None) -> None:
        if exit_status:
            self.writer.note(self._t(), f"buildhat-emulator exits with status {exit_status}")
        self.writer.close(self._t())
