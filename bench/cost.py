"""What the emulator costs: CPU with four ports streaming, memory after many lines."""
from __future__ import annotations

import os
import time
from typing import Dict

from ..harness.session import Session
from ..harness.targets import open_target
from .fidelity import wait_settled

# Powered up before the host opens the port: the devices' set-up is not what is measured.
FOUR_MOTORS = "emulator:latest?speed=1&booted=1&device=0=0x30&device=1=0x30&device=2=0x31&device=3=0x41"


def _cpu_seconds(pid: int) -> float:
    """utime + stime of a process (and its reaped children) from /proc, in seconds."""
    with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
        fields = fh.read().rsplit(")", 1)[1].split()
    ticks = sum(int(x) for x in fields[11:15])  # utime stime cutime cstime
    return ticks / os.sysconf("SC_CLK_TCK")


def streaming_cpu(url: str = FOUR_MOTORS, seconds: float = 5.0) -> Dict:
    """CPU share of one core used by the emulator process while all four ports report every
    10 ms (`select 1 ; selrate 10`, R5+), the host reading everything."""
    s = Session(open_target(url)).open()
    try:
        wait_settled(s, attempts=200)
        s.command(" ; ".join(f"port {p} ; select 1 ; selrate 10" for p in range(4)))
        pid = s.target.child.pid  # type: ignore[attr-defined]
        s.collect(0.5)
        c0, t0 = _cpu_seconds(pid), time.monotonic()
        events = s.collect(seconds)
        c1, t1 = _cpu_seconds(pid), time.monotonic()
        s.command("port 0 ; select ; port 1 ; select ; port 2 ; select ; port 3 ; select")
    finally:
        s.close()
    lines = sum(1 for e in events if e.kind == "mode_data")
    return {"cpu_pct": 100.0 * (c1 - c0) / (t1 - t0), "lines_per_s": lines / (t1 - t0)}


def _rss_kib() -> int:
    with open("/proc/self/status", encoding="ascii") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def memory_after_lines(lines: int = 1_000_000, batch: int = 100) -> Dict:
    """:func:`memory_in_this_process` in a fresh process, so the figure is the emulator's own
    (plus the interpreter), not whatever the benchmark process loaded before."""
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(1) as pool:
        return pool.apply(memory_in_this_process, (lines, batch))


def memory_in_this_process(lines: int = 1_000_000, batch: int = 100) -> Dict:
    """Resident memory of an in-process emulator (virtual time) after ``lines`` host lines,
    with its output read and discarded as a host would. Batches stay well below the
    firmware's 8192-byte receive ring, and every line's answer is counted, so no line is
    silently dropped."""
    from ..emulator import Emulator

    emu = Emulator()
    emu.boot()
    emu.read()
    chunk = b"vin ; port 1 ; version ; port 0\r" * batch
    rss0, t0 = _rss_kib(), time.monotonic()
    answered = 0
    for _ in range(lines // batch):
        emu.write(chunk)
        emu.advance(2)
        answered += emu.read().count(b" V\r\n")
    elapsed = time.monotonic() - t0
    if answered != lines // batch * batch:
        raise RuntimeError(f"{answered} of {lines} lines answered")
    return {"rss_mib": _rss_kib() / 1024.0, "rss_growth_mib": (_rss_kib() - rss0) / 1024.0,
            "lines_per_s": lines / elapsed}
