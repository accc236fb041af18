"""PNG plots for the report (matplotlib, the optional ``plots`` extra).

Every function returns PNG bytes, or None when matplotlib is not installed; the report then
shows the same numbers as a short table, so it stays complete without the extra.
"""
from __future__ import annotations

import io
from dataclasses import dataclass
from typing import List, Optional

from ..transcript import iter_events
from .series import PidSeries, WaveRun, ideal_setpoint, pid_series, wave_runs
from .timing import Timing

__all__ = ["Plot", "have_matplotlib", "plot_pid", "plot_wave", "plots_for_transcript", "plot_histogram",
           "timing_plots"]


@dataclass
class Plot:
    title: str
    kind: str                 # pid | waveform
    png: Optional[bytes]      # None without matplotlib
    summary: List[str]        # the numbers in words, shown with or without the picture


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def _figure(rows: int):
    import matplotlib

    matplotlib.use("Agg")  # no display here, and never a network or GUI toolkit
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(rows, 1, figsize=(8, 2.6 * rows), sharex=True, squeeze=False)
    return plt, fig, [a[0] for a in axes]


def _png(plt, fig, rows: int) -> bytes:
    buf = io.BytesIO()
    # Fixed margins (tight_layout measures every label and costs more than the drawing); the
    # x label needs the same inches whatever the figure's height.
    fig.subplots_adjust(left=0.1, right=0.98, top=1 - 0.3 / (2.6 * rows), bottom=0.5 / (2.6 * rows),
                        hspace=0.12)
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    return buf.getvalue()


def plot_pid(s: PidSeries, title: str) -> Optional[bytes]:
    """Process variable and set-point (top), controller output before the ±1 clamp (bottom)."""
    if not have_matplotlib():
        return None
    plt, fig, (top, bottom) = _figure(2)
    top.plot(s.t, s.sp, label="set-point (sp)", color="#d62728", drawstyle="steps-post")
    top.plot(s.t, s.pv, label="process variable (pv)", color="#1f77b4")
    top.set_ylabel("pv, sp")
    top.legend(loc="best", fontsize=8)
    top.set_title(title, fontsize=10)
    bottom.plot(s.t, s.cv, label="output (cv)", color="#2ca02c")
    for y in (-1.0, 1.0):
        bottom.axhline(y, color="#999999", linewidth=0.8, linestyle="--")
    bottom.set_ylabel("cv (±1 = full drive)")
    bottom.set_xlabel("time (ms)")
    bottom.legend(loc="best", fontsize=8)
    return _png(plt, fig, 2)


def plot_wave(run: WaveRun, title: str) -> Optional[bytes]:
    """Measured set-point (debug 16 ``sp``) as points over the ideal continuous waveform."""
    if not have_matplotlib():
        return None
    plt, fig, (ax,) = _figure(1)
    end = run.measured_t[-1] if run.measured_t else run.t0 + 2000 * run.period
    n = 400
    ts = [run.t0 + (end - run.t0) * i / n for i in range(n + 1)]
    ax.plot(ts, [ideal_setpoint(run, t) for t in ts], color="#999999",
            label="oracle: the shape the command asks for")
    ax.plot(run.measured_t, run.measured_sp, ".", color="#d62728", markersize=3,
            label="measured sp (debug 16)")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("set-point")
    ax.set_title(title, fontsize=10)
    ax.legend(loc="best", fontsize=8)
    return _png(plt, fig, 1)


def _varies(s: PidSeries) -> bool:
    """A run where pv, sp and cv never move (a port left in PID mode with nothing to do) shows
    nothing worth a picture."""
    return any(len({x for x in xs if x == x}) > 1 for xs in (s.pv, s.sp, s.cv))


def _pid_summary(s: PidSeries) -> List[str]:
    def rng(xs):
        vals = [x for x in xs if x == x]
        return f"{min(vals):g} .. {max(vals):g}" if vals else "none"
    return [f"{len(s.t)} samples on P{s.port}, t = {s.t[0]:g} .. {s.t[-1]:g} ms",
            f"pv {rng(s.pv)}; sp {rng(s.sp)}; cv {rng(s.cv)}",
            f"last: pv={s.pv[-1]:g} sp={s.sp[-1]:g} cv={s.cv[-1]:g}"]


def _wave_summary(run: WaveRun) -> List[str]:
    head = (f"P{run.port} {run.shape} {run.a:g} .. {run.b:g}, period {run.period:g} s, phase {run.phase:g}, "
            f"from t={run.t0:g} ms")
    if not run.measured_t:
        return [head, "no debug 16 samples for this port: nothing measured"]
    err = [abs(sp - ideal_setpoint(run, t)) for t, sp in zip(run.measured_t, run.measured_sp)]
    return [head, f"{len(err)} samples; largest distance from the ideal {max(err):g}, "
                  f"mean {sum(err) / len(err):g}"]


def plots_for_transcript(path: str, label: str = "", min_samples: int = 1) -> List[Plot]:
    """A waveform plot per ``set <shape>`` with measurements, and a PID plot per port in PID mode
    (each with at least ``min_samples`` debug 16 samples)."""
    events = list(iter_events(path))
    name = label or path
    plots: List[Plot] = []
    for run in wave_runs(events):
        if len(run.measured_t) >= min_samples:
            title = f"{name}: P{run.port} set {run.shape} {run.a:g} {run.b:g} {run.period:g} {run.phase:g}"
            plots.append(Plot(title, "waveform", plot_wave(run, title), _wave_summary(run)))
    for port, s in sorted(pid_series(events).items()):
        if len(s.t) < min_samples or not _varies(s):
            continue
        title = f"{name}: PID on P{port}"
        plots.append(Plot(title, "pid", plot_pid(s, title), _pid_summary(s)))
    return plots


def plot_histogram(values: List[float], title: str, xlabel: str) -> Optional[bytes]:
    if not have_matplotlib() or not values:
        return None
    plt, fig, (ax,) = _figure(1)
    ax.hist(values, bins=min(40, max(5, len(values) // 5)), color="#1f77b4")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("count")
    ax.set_title(title, fontsize=10)
    return _png(plt, fig, 1)


def timing_plots(timing: Timing) -> List[Plot]:
    """The run's report-period histogram and done-lateness histogram, each with its numbers."""
    out: List[Plot] = []
    if timing.periods:
        p = sorted(timing.periods)
        title = "Report period: time between data lines of one port"
        out.append(Plot(title, "periods", plot_histogram(p, title, "ms between lines"), [
            f"{len(p)} intervals; median {p[len(p) // 2]:g} ms, min {p[0]:g} ms, max {p[-1]:g} ms "
            "(FIRMWARE-FACTS §6.2: the reporting engine's period)"]))
    if timing.lateness:
        late = timing.lateness
        worst = max(range(len(late)), key=lambda i: abs(late[i]))
        title = "pulse/ramp done: lateness after the requested period"
        out.append(Plot(title, "lateness", plot_histogram(late, title, "ms after t0 + period"), [
            f"{len(late)} done line(s); lateness {min(late):g} .. {max(late):g} ms "
            f"(worst: {timing.lateness_labels[worst]}); FIRMWARE-FACTS §7.1: the end comes after the "
            "period's ticks, the first 0-10 ms after the command"]))
    return out
