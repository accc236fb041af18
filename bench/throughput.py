"""Fuzz throughput: checked command lines per second, in-process, over a pty (one and three
emulators at once) and on a baud-paced link.

What is timed is the fuzzer's execute-and-check path, the part every campaign step goes
through: :meth:`fuzz.runner.Runner.exchange` with a batch of inputs sent back to back (each
followed by its fence), the reference model predicting every line and the liveness, fate,
state and hygiene oracles judging every answer, on inputs drawn beforehand from the fuzzer's
own strategies. In-process and over a pty that is the fuzzer's own measurement
(``fuzz.bench.measure_throughput``); the paced link needs batches cut to the TX ring, so it
uses :func:`checked_rate` here. Hypothesis' generation and shrinking are not in these figures
(``campaign_rate`` measures a whole campaign, for comparison).

A finding (an oracle failure) is not a benchmark error: it is counted, the run restarts on a
fresh target and the count goes into the note.
"""
from __future__ import annotations

import random
import time
from typing import Dict, List, Optional

from ..harness.targets import make_target
from ..protocol.profiles import Profile, get_profile

WIRE_BYTES_PER_S = 11520.0     # 115200 baud, 8N1: ten bits a byte (FIRMWARE-FACTS §1)
POOL_SIZE = 400
# Inputs per exchange. On a baud-paced link the batch is also bounded by the bytes it will
# print (see _batches): the firmware drops output once its 8192-byte TX ring is full.
BATCH = 32
_POOLS: Dict[tuple, List[bytes]] = {}     # drawn once per process: drawing is not what is timed


def input_pool(profile: Profile, n: int = POOL_SIZE, seed: int = 1) -> List[bytes]:
    """``n`` inputs from the fuzzer's strategies (every family), reproducibly."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import seed as hseed

    from ..fuzz.grammar import grammar_for
    from ..fuzz.strategies import fuzz_input

    key = (profile.name, n, seed)
    if key in _POOLS:
        return list(_POOLS[key])
    pool: List[bytes] = []

    @hseed(seed)
    # HealthCheck iterates via an untyped metaclass __iter__: pyright cannot see its members
    @settings(max_examples=n, database=None, deadline=None,
              suppress_health_check=list(HealthCheck))  # pyright: ignore[reportArgumentType]
    @given(fuzz_input(grammar_for(profile)))
    def draw(inp) -> None:  # type: ignore[no-untyped-def]
        pool.append(inp.data)

    draw()
    _POOLS[key] = list(pool)
    return pool


def synchronous(profile: Profile, pool: List[bytes]) -> List[bytes]:
    """The inputs whose whole answer is synchronous: from the prelude state they leave debug
    output off, no port reporting and start no waveform (whose ``pulse done`` comes later).

    For the paced-link figure only. There, an asynchronous line can arrive half-way through an
    echo or after the fence, which the fuzzer's stream matcher (fuzz/stream.py) reports as a
    hygiene finding; the restart that follows would measure the emulator's start-up, not the
    wire."""
    base = _prelude_model(profile)
    out = []
    for data in pool:
        m = base.clone()
        m.feed(data)
        if m.debug or m.tainted or any(p.reporting(m.selrate_engine) for p in m.ports):
            continue
        if any(w in data for w in (b"se", b"pu", b"ra", b"s ", b"s;")):
            continue    # a waveform may have been started (the model does not predict its end)
        out.append(data)
    return out


def _prelude_model(profile: Profile):  # type: ignore[no-untyped-def]
    from ..fuzz.link import FENCE
    from ..fuzz.model import HatModel
    from ..fuzz.runner import PRELUDE

    m = HatModel(profile)
    m.feed(PRELUDE + FENCE)
    return m


def _predicted_bytes(model, data: bytes) -> int:  # type: ignore[no-untyped-def]
    """Bytes the model says ``data`` (and its fence) will print; the model is advanced."""
    from ..fuzz.link import FENCE
    items, _ = model.feed(data)
    fence, _ = model.feed(FENCE)
    return sum(len(i.data) if i.kind == "exact" else (4000 if i.kind == "listing" else 80)
               for i in items + fence)


def checked_rate(url: str, seconds: float, out_limit: Optional[int] = None, seed: int = 1,
                 only_synchronous: bool = False, batch_size: int = BATCH) -> Dict:
    """Lines/s through ``Runner.exchange`` on ``url`` for about ``seconds`` of wall time.

    ``out_limit``: cap the predicted output of one batch (bytes), for paced links.
    Returns lines_per_s and the byte counts both ways (fences included: they cross the wire)."""
    from ..fuzz.link import FENCE
    from ..fuzz.oracles import Finding
    from ..fuzz.runner import Runner, guard_debug

    profile = get_profile(None)
    pool = input_pool(profile, seed=seed)
    if only_synchronous:
        pool = synchronous(profile, pool)
    sizes: Dict[bytes, int] = {}
    if out_limit is not None:
        # Computed once, from the prelude state, plus the input's length in case echo is on:
        # an upper bound cheap enough to leave the link no idle time between batches.
        sizes = {d: _predicted_bytes(_prelude_model(profile), d) + len(d) for d in pool}
        pool = [d for d in pool if sizes[d] <= out_limit]   # alone it would overflow (`? ?`)
    rng = random.Random(seed)

    def fresh() -> Runner:
        r = Runner([("target", lambda: make_target(url), profile)], fence_s=5.0)
        r.start()
        return r

    runner = fresh()
    lines = findings = 0
    restarts = 0.0
    start = time.monotonic()
    cpu0 = time.process_time()
    try:
        link = runner.sides[0].link
        sent0 = _bytes(link, "send")
        recv0 = _bytes(link, "recv")
        sent = recv = 0
        while time.monotonic() - start < seconds:
            batch: List[bytes] = []
            out = 0
            while len(batch) < batch_size:
                data = rng.choice(pool)
                if out_limit is not None:
                    # The TX ring holds what is printed faster than the wire carries it away;
                    # input arrives at the same rate, so the backlog grows by (out - in).
                    grow = sizes[data] - len(data) - len(FENCE)
                    if out + grow > out_limit:
                        break
                    out += max(grow, 0)
                batch.append(data)
            datas, ahead = guard_debug(runner.sides[0].model, batch)
            try:
                runner.exchange(datas, ahead)
            except Finding:
                findings += 1
                sent += _bytes(link, "send") - sent0
                recv += _bytes(link, "recv") - recv0
                t_restart = time.monotonic()
                runner.close()
                runner = fresh()
                # A new emulator's start-up is not exchange throughput: its time is left out
                # (and reported). The finding itself is counted in the note.
                restarts += time.monotonic() - t_restart
                link = runner.sides[0].link
                sent0, recv0 = _bytes(link, "send"), _bytes(link, "recv")
                continue
            lines += sum(d.count(b"\r") for d in datas)
        total = time.monotonic() - start
        elapsed = total - restarts
        cpu = time.process_time() - cpu0
        sent += _bytes(link, "send") - sent0
        recv += _bytes(link, "recv") - recv0
    finally:
        runner.close()
    return {"lines_per_s": lines / elapsed, "lines": lines, "seconds": elapsed, "findings": findings,
            # this process only (in-process: the whole fuzzer and emulator; the wall figure is
            # what counts, this one says how much a loaded machine took away)
            "lines_per_cpu_s": lines / cpu if cpu > 0 else 0.0,
            "sent_bytes_per_s": sent / elapsed, "recv_bytes_per_s": recv / elapsed,
            "lines_per_s_with_restarts": lines / total, "restart_s": restarts,
            "note": f"{findings} finding(s); {restarts:.1f} s of restarts left out" if findings else ""}


def _bytes(link, kind: str) -> int:  # type: ignore[no-untyped-def]
    return sum(len(e[2]) for e in link.trace.entries if e[0] == kind)


# In-process and over a pty the fuzzer's own measurement is used (fuzz/bench.py, its fast path:
# a seeded pool, pipelined batches of the fuzzer's default size, every oracle on).
FUZZ_BATCH = 8


def _fuzz_measure(url: str, seconds: float) -> Dict:
    from ..fuzz.bench import measure_throughput

    res = dict(measure_throughput(url, seconds=seconds, batch=FUZZ_BATCH))
    findings = res.get("findings")
    n = findings if isinstance(findings, int) else 0
    res["note"] = f"batch {FUZZ_BATCH}" + (f"; {n} finding(s), restarts included" if n else "")
    return res


def inprocess(seconds: float = 5.0) -> Dict:
    """The emulator in this process, virtual time: the cost of model + emulator + oracles."""
    return _fuzz_measure("inprocess", seconds)


def over_pty(seconds: float = 5.0) -> Dict:
    """The emulator as its own process at real time, through a pty (no baud pacing)."""
    return _fuzz_measure("emulator:latest?speed=1", seconds)


def baud_paced(seconds: float = 8.0, baud: int = 115200) -> Dict:
    """Share of the 115200-baud wire the fuzzer keeps busy against ``--baud 115200``: the
    busier direction's bytes/s over 11,520 bytes/s. Batches are cut so their predicted output
    fits in the TX ring, as a host that respects the firmware's buffering would."""
    res = checked_rate(f"emulator:latest?speed=1&baud={baud}", seconds, out_limit=6000,
                       only_synchronous=True, batch_size=256)
    wire = baud / 10.0
    res["wire_share_pct"] = 100.0 * max(res["sent_bytes_per_s"], res["recv_bytes_per_s"]) / wire
    return res


def campaign_rate(seconds: float = 5.0) -> Dict:
    """A whole Hypothesis campaign in-process (generation and shrinking included), for comparison."""
    from ..fuzz.campaign import parse_budget, run_campaign
    from ..fuzz.machine import FuzzConfig
    from ..fuzz.runner import Stats

    stats = Stats()
    config = FuzzConfig(open_primary=lambda: make_target("inprocess"), profile=get_profile(None), stats=stats)
    result = run_campaign(config, parse_budget(f"{seconds:g}s"), seed=1)
    return {"lines_per_s": stats.lines / max(result.elapsed, 1e-9), "findings": len(result.findings)}


def _one_pty(seconds: float, seed: int) -> Dict:
    from ..fuzz.bench import measure_throughput

    return dict(measure_throughput("emulator:latest?speed=1", seconds=seconds, batch=FUZZ_BATCH,
                                   seed_value=seed))


def parallel_ptys(n: int = 3, seconds: float = 5.0) -> Dict:
    """``n`` fuzzers, each with its own emulator process over its own pty, at once (one
    process each, as ``n`` campaigns on a lab machine would run): their lines/s summed."""
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=n) as pool:
        results = list(pool.map(_one_pty, [seconds] * n, range(1, n + 1)))
    findings = sum(r["findings"] for r in results)
    return {"lines_per_s": sum(r["lines_per_s"] for r in results), "targets": n,
            "per_target": [r["lines_per_s"] for r in results],
            "note": f"{n} emulators" + (f", {findings} finding(s), restarts included" if findings else "")}
