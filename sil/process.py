"""One run of a firmware built with the stand-in: the child process and its frames.

:class:`FirmwareProcess` starts the program, checks its hello, and runs it to a virtual time
(:meth:`run`), returning what it did on the way. :meth:`fork` makes a copy of a running
firmware at its current state (the program forks; the copy talks over a socket): a booted HAT
is started once and copied for each fuzzing run. A program that exits, crashes (a sanitizer
report, a signal) or stops answering raises :class:`FirmwareDied` with what it left on stderr:
the summary says what happened, ``report`` is all of it.
"""
from __future__ import annotations

import os
import re
import select
import shutil
import signal
import socket
import struct
import subprocess
import tempfile
from typing import List, Optional, Sequence, Tuple

from .frames import HEADER, HELLO, Frame, FrameType, encode
from .sanitizer_reports import FirmwareReport, crash_report, split_reports

__all__ = ["FirmwareProcess", "FirmwareDied", "HANG_S"]

# A firmware that has not yielded after this much wall time is taken as hung (an endless
# loop inside an interrupt handler never gives the clock back).
HANG_S = 20.0
_SANITIZER_EXIT = 86
# What the stand-in prints as a fatal signal no sanitizer handles kills the program
# (standin/frame_transport.c).
_SAID_SIGNAL = re.compile(r"sil: the firmware was killed by (SIG[A-Z]+)")


class FirmwareDied(RuntimeError):
    """The firmware process ended or hung. ``kind`` is ``crashed`` (signal or sanitizer),
    ``exited`` (it called exit) or ``hung``; ``report`` is its stderr; ``frames`` what it sent
    before it died."""

    def __init__(self, kind: str, summary: str, report: str = ""):
        super().__init__(summary)
        self.kind, self.summary, self.report = kind, summary, report
        self.frames: List[Frame] = []
        self.findings: List[FirmwareReport] = []     # its reports, the fatal one last


def _first_report_line(text: str) -> str:
    for line in text.splitlines():
        line = line.strip()
        if line.startswith(("==", "SUMMARY:")) or "runtime error" in line or "ERROR:" in line:
            return line.lstrip("=0123456789 ")
    for line in text.splitlines():
        if line.strip():
            return line.strip()
    return ""


def _last_word(text: str) -> str:
    """The last line a crashed program wrote that is not the stand-in's signal line: the rp2040
    runner's one line on where the core stopped (rp2040/README.md, "Crashes"); a plain build says
    nothing more."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not _SAID_SIGNAL.search(ln)]
    return lines[-1] if lines else ""


def _sanitizer(report: str) -> str:
    for name in ("AddressSanitizer", "UndefinedBehaviorSanitizer", "LeakSanitizer"):
        if name in report:
            return name
    return "UndefinedBehaviorSanitizer" if "runtime error" in report else "sanitizer"


class FirmwareProcess:
    def __init__(self, program: str, env: Optional[dict] = None, args: Sequence[str] = ()):
        self.program = program
        self._tmp = tempfile.mkdtemp(prefix="sil-")
        self._stderr_path = os.path.join(self._tmp, "stderr.txt")
        run_env = dict(os.environ if env is None else env)
        # A report the sanitizer can go on after does not end the program (the build recovers,
        # sil/build.py): every report of a run is seen, each by the case that met it. One it
        # cannot go on after ends it with a clear status (and no core dump).
        run_env.setdefault("ASAN_OPTIONS", f"abort_on_error=0:halt_on_error=0:exitcode={_SANITIZER_EXIT}"
                                           ":detect_leaks=0")
        run_env.setdefault("UBSAN_OPTIONS", f"halt_on_error=0:exitcode={_SANITIZER_EXIT}:print_stacktrace=1")
        self.proc: Optional[subprocess.Popen] = None
        self.conn: Optional[socket.socket] = None
        try:
            with open(self._stderr_path, "wb") as err:
                self.proc = subprocess.Popen([program, *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                             stderr=err, env=run_env, bufsize=0, start_new_session=True)
        except OSError as exc:
            shutil.rmtree(self._tmp, ignore_errors=True)
            raise FirmwareDied("exited", f"cannot start {program}: {exc.strerror}") from None
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.pid = self.proc.pid
        self._rfd, self._wfd = self.proc.stdout.fileno(), self.proc.stdin.fileno()
        self._start()

    def _start(self) -> None:
        self.reports: List[FirmwareReport] = []     # reports not yet taken (take_reports)
        self._stderr_read = 0
        self._buf = bytearray()
        self.now = 0
        self.ended: Optional[FirmwareDied] = None
        # At the last yield nothing was leaving or arriving on the command port (frames.py, FrameType.YIELD).
        self.host_quiet = False
        hello, _frames = self._until(FrameType.YIELD)
        if hello.payload[:4] != HELLO:
            self.kill()
            raise FirmwareDied("exited", f"{self.program} is not a firmware built with the stand-in "
                                         f"(hello {hello.payload!r})")
        self.now = hello.t

    # -- copies ----------------------------------------------------------------------------
    def fork(self) -> FirmwareProcess:
        """A copy of this firmware as it is now (between two runs), as its own process."""
        tmp = tempfile.mkdtemp(prefix="sil-")
        path = os.path.join(tmp, "s")
        listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            listener.bind(path)
            listener.listen(1)
            listener.settimeout(HANG_S)
            stderr_path = os.path.join(tmp, "stderr.txt")
            self.send(encode(FrameType.COPY, 0, path.encode() + b"\0" + stderr_path.encode()))
            answer, _frames = self._until(FrameType.COPY_MADE)
            pid = struct.unpack("<i", answer.payload[:4])[0]
            if pid < 0:
                raise FirmwareDied("exited", f"the firmware could not be copied (fork: {os.strerror(-pid)})")
            conn, _ = listener.accept()
        except (OSError, socket.timeout) as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            raise FirmwareDied("exited", f"the firmware could not be copied: {exc}") from None
        finally:
            listener.close()
        copy = FirmwareProcess.__new__(FirmwareProcess)
        copy.program, copy._tmp, copy._stderr_path = self.program, tmp, stderr_path
        copy.proc, copy.conn, copy.pid = None, conn, pid
        copy._rfd = copy._wfd = conn.fileno()
        copy._start()
        return copy

    # -- frames ------------------------------------------------------------------------------
    def send(self, data: bytes) -> None:
        view = memoryview(data)
        try:
            while view:
                n = os.write(self._wfd, view)
                view = view[n:]
        except OSError:
            raise self._died([]) from None

    def run(self, limit_ns: int, inputs: Sequence[bytes] = (), yield_on_host_idle: bool = False
            ) -> List[Frame]:
        """Send ``inputs`` (encoded frames), run to ``limit_ns`` or the firmware's own yield,
        and return its frames (``self.now`` is where it stopped)."""
        flags = b"\x01" if yield_on_host_idle else b"\x00"
        self.send(b"".join(inputs) + encode(FrameType.RUN, limit_ns, flags))
        y, frames = self._until(FrameType.YIELD)
        self.now = y.t
        self.host_quiet = y.payload[:1] == b"\x03"
        self._read_reports()
        return frames

    # -- reports the firmware went on after ----------------------------------------------------
    def _read_reports(self) -> str:
        """Take the reports written to stderr since the last look (complete: the firmware writes a
        report before it runs on, and it has stopped); return the rest of what it wrote."""
        try:
            size = os.stat(self._stderr_path).st_size
        except OSError:
            return ""
        if size <= self._stderr_read:
            return ""
        with open(self._stderr_path, "rb") as fh:
            fh.seek(self._stderr_read)
            text = fh.read(size - self._stderr_read).decode("utf-8", "replace")
        self._stderr_read = size
        found, other = split_reports(text)
        self.reports.extend(found)
        return other

    def take_reports(self) -> List[FirmwareReport]:
        """The reports met since the last call (the fatal one too, once the firmware died)."""
        out, self.reports = self.reports, []
        return out

    def _until(self, kind: str) -> Tuple[Frame, List[Frame]]:
        """Frames up to the first of ``kind`` (which is returned apart)."""
        buf, size = self._buf, HEADER.size
        frames: List[Frame] = []
        i = 0
        while True:
            while len(buf) - i >= size:
                code, port, length, _spare, t = HEADER.unpack_from(buf, i)
                if len(buf) - i < size + length:
                    break
                frame = Frame(chr(code), port, t, bytes(buf[i + size:i + size + length]))
                i += size + length
                if frame.kind == kind:
                    del buf[:i]
                    return frame, frames
                frames.append(frame)
            ready, _, _ = select.select([self._rfd], [], [], HANG_S)
            if not ready:
                del buf[:i]
                self.kill()
                died = FirmwareDied("hung", f"the firmware gave no answer for {HANG_S:.0f} s of wall time "
                                            f"(an endless loop where time cannot pass)", self.stderr_text())
                died.frames = frames
                self.ended = died
                raise died
            try:
                chunk = os.read(self._rfd, 1 << 16)
            except OSError:
                chunk = b""
            if not chunk:
                del buf[:i]
                raise self._died(frames)
            buf += chunk

    # -- ending ------------------------------------------------------------------------------
    def stderr_text(self) -> str:
        try:
            with open(self._stderr_path, "rb") as fh:
                return fh.read().decode("utf-8", "replace")
        except OSError:
            return ""

    def _exit_code(self) -> Optional[int]:
        if self.proc is not None:
            try:
                return self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.kill()
                return self.proc.wait()
        return None                       # a copy is not our child: its report says what happened

    def _died(self, frames: List[Frame]) -> FirmwareDied:
        code = self._exit_code()
        report = self.stderr_text()
        seen = len(self.reports)
        other = self._read_reports()
        found = self.reports[seen:]
        first = found[-1].first if found else _first_report_line(report)
        said = _SAID_SIGNAL.search(report)
        signalled = code is not None and code < 0
        if signalled or said:
            number = -(code or 0)
            name = said.group(1) if said else (
                signal.Signals(number).name if number in signal.Signals._value2member_map_ else str(number))
            if found:
                died = FirmwareDied("crashed", f"the firmware crashed ({name}): {first}", report)
            else:             # no sanitizer said where: the program's own last line, if it said one
                found = [crash_report(name, report, _last_word(other))]
                self.reports.extend(found)
                died = FirmwareDied("crashed", found[0].first, report)
        elif code == _SANITIZER_EXIT or found:
            which = _sanitizer(found[-1].text if found else report)
            died = FirmwareDied("crashed", f"the firmware crashed ({which}): {first or 'sanitizer report'}",
                                report)
        elif code is None:
            died = FirmwareDied("exited", "the firmware ended" + (f": {first}" if first else ""), report)
        else:
            died = FirmwareDied("exited", f"the firmware exited with status {code}"
                                + (f": {first}" if first else ""), report)
        if found and died.kind == "crashed":
            found[-1].fatal = True
        died.findings = found
        died.frames = frames
        self.ended = died
        return died

    def kill(self) -> None:
        if self.proc is not None:
            if self.proc.poll() is None:
                try:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                except OSError:
                    self.proc.kill()
                self.proc.wait()
        else:
            try:
                os.kill(self.pid, signal.SIGKILL)
            except OSError:
                pass
        self._close_fds()

    def _close_fds(self) -> None:
        if self.conn is not None:
            self.conn.close()
            self.conn = None
        if self.proc is not None:
            for f in (self.proc.stdin, self.proc.stdout):
                if f is not None:
                    try:
                        f.close()
                    except OSError:
                        pass

    def quit(self, timeout: float = 10.0) -> None:
        """Let the firmware exit cleanly (coverage data is written), else kill it."""
        gone = False
        try:
            if self.ended is None:
                self.send(encode(FrameType.QUIT))
                if self.proc is not None:
                    self.proc.wait(timeout=timeout)
                    gone = True
                else:                     # a copy: its end of the socket closes when it has exited
                    gone = bool(select.select([self._rfd], [], [], timeout)[0])
        except (OSError, FirmwareDied, subprocess.TimeoutExpired):
            pass
        if gone:
            self._close_fds()
        else:
            self.kill()
        shutil.rmtree(self._tmp, ignore_errors=True)
