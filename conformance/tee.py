"""A target wrapper that copies every byte, both ways, into the current test's transcript.

The session is shared by the whole run, but each test case gets its own transcript; this
wrapper is where the switch happens. Bytes that arrive between test cases go to the run's
own transcript, so nothing received is ever lost.
"""
from __future__ import annotations

import threading
import time
from typing import Optional

from ..harness.targets.base import NotReading, Target
from ..harness.transcript import TranscriptWriter

__all__ = ["TeeTarget", "VirtualTeeTarget", "tee"]


def tee(inner: Target, between: Optional[TranscriptWriter] = None) -> TeeTarget:
    """The wrapper for ``inner``: one that keeps its virtual clock visible where it has one, so
    the session steps it in HAT time instead of pacing it against the wall clock."""
    if inner.has("virtual_time") and hasattr(type(inner), "now"):
        return VirtualTeeTarget(inner, between)
    return TeeTarget(inner, between)


class TeeTarget(Target):
    def __init__(self, inner: Target, between: Optional[TranscriptWriter] = None):
        self.inner = inner
        self.url = inner.url
        self.capabilities = inner.capabilities
        self.control = inner.control
        self.disposable = inner.disposable
        self.reset_hint = inner.reset_hint
        self.between = between
        self.current: Optional[TranscriptWriter] = None
        self._t0 = time.monotonic()
        self._hat0 = 0.0
        self.dead: Optional[str] = None        # why the target went away, once it has
        # The session may read from a thread while the test thread writes.
        self._lock = threading.Lock()

    def _writer(self) -> Optional[TranscriptWriter]:
        return self.current or self.between

    def _now_ms(self) -> float:
        # Transcript times are HAT milliseconds (TRANSCRIPT.md): real time x the time scale.
        return (time.monotonic() - self._t0) * 1000.0 * (self.inner.time_scale or 1.0)

    def switch(self, writer: Optional[TranscriptWriter]) -> None:
        """Route from now on to ``writer`` (None: the between-tests transcript); times restart."""
        with self._lock:
            old = self._writer()
            if old is not None:
                old.flush_partial(self._now_ms())
            self.current = writer
            self._t0 = time.monotonic()

    def open(self) -> None:
        self.inner.open()
        self.control = self.inner.control
        self.capabilities = self.inner.capabilities

    def write(self, data: bytes) -> None:
        with self._lock:
            w = self._writer()
            if w is not None:
                w.host(self._now_ms(), data)
        try:
            self.inner.write(data)
        except NotReading:
            raise       # a target fault, but it may read again: the run's fault count decides
        except Exception as exc:
            self.dead = self.dead or f"{type(exc).__name__}: {exc}"
            raise

    def read(self, timeout: float) -> bytes:
        try:
            data = self.inner.read(timeout)
        except Exception as exc:
            self.dead = self.dead or f"{type(exc).__name__}: {exc}"
            report = getattr(exc, "report", "")
            if report:                   # a crashed firmware's whole report goes in the transcript
                with self._lock:
                    w = self._writer()
                    if w is not None:
                        w.note(self._now_ms(), report)
            raise
        with self._lock:
            w = self._writer()
            if w is not None:
                if data:
                    w.hat(self._now_ms(), data)
                # A half line that has waited for its CRLF goes to disk now: kill -9 loses nothing.
                w.flush_stale()
        return data

    def note(self, text: str) -> None:
        """A note (a firmware's sanitizer report) in the transcript now being written."""
        with self._lock:
            w = self._writer()
            if w is not None:
                w.note(self._now_ms(), text)

    def revived(self) -> None:
        """The target's HAT was started again after it died (conformance/plugin/firmware_findings.py)."""
        self.dead = None

    def close(self) -> None:
        self.inner.close()

    @property  # type: ignore[override]
    def is_open(self) -> bool:
        return bool(getattr(self.inner, "is_open", False))

    def diagnose(self, problem: str) -> str:
        return self.inner.diagnose(problem)

    @property
    def time_scale(self) -> float:
        return self.inner.time_scale

    def has(self, capability: str) -> bool:
        return self.inner.has(capability)


class VirtualTeeTarget(TeeTarget):
    """A tee for a virtual-time target (``inprocess``): its clock shows through, and transcript
    times are HAT milliseconds read off it rather than the wall clock."""

    @property
    def now(self) -> float:
        return float(self.inner.now)  # type: ignore[attr-defined]

    def advance(self, ms: int) -> None:
        self.inner.advance(ms)  # type: ignore[attr-defined]

    def _hat_ms(self) -> float:
        try:
            return float(self.inner.now)  # type: ignore[attr-defined]
        except Exception:  # noqa: BLE001 - not open yet / closed: transcript time 0
            return 0.0

    def _now_ms(self) -> float:
        return self._hat_ms() - self._hat0

    def switch(self, writer: Optional[TranscriptWriter]) -> None:
        super().switch(writer)
        self._hat0 = self._hat_ms()

    def open(self) -> None:
        super().open()
        self._hat0 = self._hat_ms()
