"""``buildhat-conformance record``: keep a transcript of a scenario, or of a host program's session.

``record SCRIPT --target URL -o FILE`` runs a scenario script on any target (sends, waits and,
where the target has the control, world actions) through the one script runner
(transcripts/script_runner.py, as ``script`` and ``replay`` do): in-process targets in virtual time,
the rest in real time. A script whose world actions or start-up layout the target cannot
perform is refused with what is missing; it is never run halfway.

``record --proxy --target URL -o FILE [-- COMMAND ...]`` puts a pseudo-terminal in front of the
target and records everything a host program (e.g. the ``buildhat`` library) and the HAT say to
each other; ``{device}`` in COMMAND becomes the pty path (also in $BUILDHAT_DEVICE). t = 0 is
the host's first byte; what the HAT said before is start-up (t < 0). Such a recording is what
``mock`` serves.

The meta header holds the target, firmware, tool version, date and (for scripts) the script
path relative to the transcript, so ``replay`` can find it.
"""
from __future__ import annotations

import datetime
import os
import select
import subprocess
import threading
import time
from typing import List, Optional, Sequence, Tuple

from ..harness.targets.base import TargetError
from ..harness.transcript import Transcript, TranscriptWriter, read_transcript
from ..plumbing.cli_options import BOOT_TIMEOUT_S
from ..plumbing.raw_pty import open_raw_pty
from .replay import write_transcript
from .script import Script
from .script_runner import run_script

__all__ = ["record_script", "record_proxy", "ready_lines"]


def _now_iso() -> str:
    return datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat()


def _tool_version() -> str:
    from ..plumbing.package_version import __version__

    return __version__


def ready_lines(layout: dict) -> List[str]:
    """The start-up lines that show the layout is up (FIRMWARE-BEHAVIOUR.md#fb-async): each active device
    established, each passive device connected; with no device, the end of port initialisation."""
    out = []
    for port, spec in sorted(layout.items()):
        if spec is None:
            continue
        kind, ident = spec
        if kind == "active":
            out.append(f"P{port}: established serial communication with active ID {ident:02X}")
        else:
            out.append(f"P{port}: connected to passive ID {ident}")
    return out or ["Done initialising ports"]


def record_script(script: Script, target, out: str,  # type: ignore[no-untyped-def]
                  boot_timeout: float = BOOT_TIMEOUT_S) -> Tuple[Transcript, List[str]]:
    """Run ``script`` on ``target`` through the one script runner (transcripts/script_runner.py)
    and write the transcript to ``out`` as it runs; returns it and remarks. Raises
    NeedsCapability (saying what is missing) before anything is sent, TargetError when the
    target could not be opened or stopped mid-run (the transcript keeps what came until then).
    ``boot_timeout``: HAT seconds a booting target has to bring up the script's layout."""
    rel_script = os.path.relpath(os.path.abspath(script.source), os.path.dirname(os.path.abspath(out))) \
        if os.path.isfile(script.source) else script.source
    meta = {"script": rel_script, "tool": f"buildhat-conformance {_tool_version()} record",
            "date": _now_iso()}
    result = run_script(script, target, transcript=out, meta=meta,
                        layout_wait_s=boot_timeout)
    if not result.ok:
        raise TargetError(f"{result.reason}; the transcript {out} keeps every byte received until then")
    return read_transcript(out), list(result.notes)


# -- proxy -------------------------------------------------------------------------------------
def record_proxy(target, out: str, command: Sequence[str] = (), link: Optional[str] = None,  # type: ignore
                 stop: Optional[threading.Event] = None, on_ready=None,  # type: ignore[no-untyped-def]
                 ready: Sequence[str] = (), boot_timeout: float = BOOT_TIMEOUT_S) -> int:
    """Forward between a new pty and ``target``, recording both directions, until ``command``
    exits (its status is returned) or ``stop`` is set. A target that talks when opened is
    booting: the host is let in once the ``ready`` lines have come (at most ``boot_timeout`` s)."""
    master, slave, path = open_raw_pty(link)   # raw: bytes pass as on a UART (CR stays CR)
    stop = stop or threading.Event()
    chunks: List[Tuple[float, str, bytes]] = []
    lock = threading.Lock()
    target.open()
    scale = float(target.time_scale or 1.0)

    def from_target() -> None:
        while not stop.is_set():
            try:
                data = target.read(0.05)
            except Exception as exc:  # noqa: BLE001 - the target went away: end the recording
                with lock:
                    chunks.append((time.monotonic(), "note", f"target error: {exc}".encode()))
                stop.set()
                return
            if data:
                with lock:
                    chunks.append((time.monotonic(), "hat", data))
                os.write(master, data)

    reader = threading.Thread(target=from_target, name="record-proxy", daemon=True)
    reader.start()
    if ready and boot_timeout > 0:
        _wait_for_start_up(chunks, lock, ready, boot_timeout)
    status = 0
    proc = None
    try:
        if command:
            argv = [a.replace("{device}", link or path) for a in command]
            proc = subprocess.Popen(argv, env=dict(os.environ, BUILDHAT_DEVICE=link or path))
        elif on_ready is not None:
            on_ready(link or path)
        else:
            print(link or path, flush=True)
        while not stop.is_set():
            if proc is not None and proc.poll() is not None:
                status = proc.returncode
                time.sleep(0.1)   # the HAT's answer to the host's last line
                break
            r, _, _ = select.select([master], [], [], 0.05)
            if r:
                try:
                    data = os.read(master, 4096)
                except OSError:
                    continue
                with lock:
                    chunks.append((time.monotonic(), "host", data))
                target.write(data)
    finally:
        stop.set()
        reader.join(timeout=2)
        if proc is not None and proc.poll() is None:
            proc.terminate()
            status = proc.wait(timeout=10)
        target.close()
        os.close(master)
        os.close(slave)
        if link and os.path.islink(link):
            os.unlink(link)
    last_t = chunks[-1][0] if chunks else time.monotonic()
    first_host = next((t for t, k, _d in chunks if k == "host"), last_t)
    meta = {"target": getattr(target, "url", ""), "tool": "buildhat-conformance record --proxy",
            "version": _tool_version(), "date": _now_iso(), "time_scale": scale,
            "host_command": " ".join(command) if command else ""}
    writer = TranscriptWriter(out + ".part", dict(meta, firmware="unknown"))
    write_chunks(writer, chunks, first_host, scale)
    end_t = ((chunks[-1][0] - first_host) * 1000.0 * scale) if chunks else 0.0
    writer.close(end_t)
    recorded = read_transcript(out + ".part")
    os.unlink(out + ".part")
    for line in recorded.hat_lines():
        if line.startswith("Firmware version: "):
            recorded.meta["firmware"] = line[len("Firmware version: "):]
            break
    write_transcript(recorded, out)
    return status


def write_chunks(writer: TranscriptWriter, chunks: Sequence[Tuple[float, str, bytes]], t0: float,
                 scale: float) -> None:
    """Write (monotonic time, "hat"|"host"|"note", bytes) chunks as transcript events, in HAT
    milliseconds from ``t0``."""
    for when, kind, data in chunks:
        t = (when - t0) * 1000.0 * scale
        if kind == "hat":
            writer.hat(t, data)
        elif kind == "host":
            writer.host(t, data)
        else:
            writer.flush_partial(t)
            writer.note(t, data.decode(errors="replace"))


def _wait_for_start_up(chunks: list, lock: threading.Lock, ready: Sequence[str], timeout: float) -> None:
    def stream() -> bytes:
        with lock:
            return b"\r\n" + b"".join(d for _t, k, d in chunks if k == "hat")

    talking_by = time.monotonic() + min(1.0, timeout)
    while not chunks and time.monotonic() < talking_by:
        time.sleep(0.02)
    deadline = time.monotonic() + timeout
    while chunks and time.monotonic() < deadline:
        data = stream()
        if all(b"\r\n" + line.encode() + b"\r\n" in data for line in ready):
            return
        time.sleep(0.02)
