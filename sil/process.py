"""One run of a firmware built with the stand-in: the child process and its frames.

:class:`FirmwareProcess` starts the program, checks its hello, and runs it to a virtual time
(:meth:`run`), returning what it did on the way. A program that exits, crashes (a sanitizer
report, a signal) or stops answering raises :class:`FirmwareDied` with what it left on stderr:
the first line says what happened, the rest is the whole report.
"""
from __future__ import annotations

import os
import select
import signal
import subprocess
import tempfile
from typing import List, Optional, Sequence, Tuple

from .protocol import HEADER, HELLO, Frame, encode

__all__ = ["FirmwareProcess", "FirmwareDied", "HANG_S"]

# A firmware that has not yielded after this much wall time is taken as hung (an endless
# loop inside an interrupt handler never gives the clock back).
HANG_S = 20.0


class FirmwareDied(RuntimeError):
    """The firmware process ended or hung. ``kind`` is ``crashed`` (signal or sanitizer),
    ``exited`` (it called exit) or ``hung``; ``report`` is its stderr."""

    def __init__(self, kind: str, summary: str, report: str = ""):
        super().__init__(summary)
        self.kind, self.summary, self.report = kind, summary, report
        self.frames: List[Frame] = []


def _first_report_line(text: str) -> str:
    for line in text.splitlines():
        line = line.strip()
        if line.startswith(("==", "SUMMARY:")) or "runtime error" in line or "ERROR:" in line:
            return line.lstrip("=0123456789 ")
    for line in text.splitlines():
        if line.strip():
            return line.strip()
    return ""


def _sanitizer(report: str) -> str:
    for name in ("AddressSanitizer", "UndefinedBehaviorSanitizer", "LeakSanitizer"):
        if name in report:
            return name
    return "UndefinedBehaviorSanitizer" if "runtime error" in report else "sanitizer"


class FirmwareProcess:
    def __init__(self, program: str, env: Optional[dict] = None):
        self.program = program
        self._stderr = tempfile.TemporaryFile()
        run_env = dict(os.environ if env is None else env)
        # A sanitizer report ends the program with a clear status (and no core dump).
        run_env.setdefault("ASAN_OPTIONS", "abort_on_error=0:exitcode=86:detect_leaks=0")
        run_env.setdefault("UBSAN_OPTIONS", "halt_on_error=1:exitcode=86:print_stacktrace=1")
        try:
            self.proc = subprocess.Popen([program], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=self._stderr, env=run_env, bufsize=0,
                                         start_new_session=True)
        except OSError as exc:
            raise FirmwareDied("exited", f"cannot start {program}: {exc.strerror}") from None
        self._buf = bytearray()
        self.now = 0
        hello, frames = self._until_yield()
        if hello.payload != HELLO:
            self.kill()
            raise FirmwareDied("exited", f"{program} is not a firmware built with the stand-in "
                                         f"(hello {hello.payload!r})")
        self.ended: Optional[FirmwareDied] = None

    # -- frames ------------------------------------------------------------------------------
    def send(self, data: bytes) -> None:
        try:
            assert self.proc.stdin is not None
            self.proc.stdin.write(data)
        except (BrokenPipeError, OSError):
            raise self._died() from None

    def run(self, limit_ns: int, inputs: Sequence[bytes] = (), yield_on_host_idle: bool = False
            ) -> List[Frame]:
        """Send ``inputs`` (encoded frames), run to ``limit_ns`` or the firmware's own yield,
        and return its frames (``self.now`` is where it stopped)."""
        flags = b"\x01" if yield_on_host_idle else b"\x00"
        self.send(b"".join(inputs) + encode("R", limit_ns, flags))
        y, frames = self._until_yield()
        self.now = y.t
        return frames

    def _until_yield(self) -> Tuple[Frame, List[Frame]]:
        assert self.proc.stdout is not None
        fd = self.proc.stdout.fileno()
        buf, size = self._buf, HEADER.size
        frames: List[Frame] = []
        i = 0
        while True:
            while len(buf) - i >= size:
                kind, port, length, _spare, t = HEADER.unpack_from(buf, i)
                if len(buf) - i < size + length:
                    break
                payload = bytes(buf[i + size:i + size + length])
                i += size + length
                frame = Frame(chr(kind), port, t, payload)
                if frame.kind == "y":
                    del buf[:i]
                    return frame, frames
                frames.append(frame)
            ready, _, _ = select.select([fd], [], [], HANG_S)
            if not ready:
                self.kill()
                raise FirmwareDied("hung", f"the firmware gave no answer for {HANG_S:.0f} s of wall time "
                                           f"(an endless loop where time cannot pass)", self.stderr_text())
            chunk = os.read(fd, 1 << 16)
            if not chunk:
                del buf[:i]
                died = self._died()
                died.frames = frames        # what it sent before it died is kept
                raise died
            buf += chunk

    # -- ending ------------------------------------------------------------------------------
    def stderr_text(self) -> str:
        self._stderr.seek(0)
        return self._stderr.read().decode("utf-8", "replace")

    def _died(self) -> FirmwareDied:
        try:
            code = self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.kill()
            code = self.proc.wait()
        report = self.stderr_text()
        first = _first_report_line(report)
        if code < 0:
            name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else str(-code)
            died = FirmwareDied("crashed", f"the firmware crashed ({name})" + (f": {first}" if first else ""),
                                report)
        elif code == 86 or "Sanitizer" in report or "runtime error" in report:
            died = FirmwareDied("crashed", f"the firmware crashed ({_sanitizer(report)}): "
                                           f"{first or 'sanitizer report'}", report)
        else:
            died = FirmwareDied("exited", f"the firmware exited with status {code}"
                                + (f": {first}" if first else ""), report)
        self.ended = died
        return died

    def kill(self) -> None:
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except OSError:
                self.proc.kill()
            self.proc.wait()

    def quit(self, timeout: float = 10.0) -> None:
        """Let the firmware exit cleanly (coverage data is written), else kill it."""
        if self.proc.poll() is None:
            try:
                assert self.proc.stdin is not None
                self.proc.stdin.write(encode("Q"))
                self.proc.stdin.close()
                self.proc.wait(timeout=timeout)
            except (OSError, subprocess.TimeoutExpired):
                self.kill()
        self._stderr.close()
