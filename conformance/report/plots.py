"""The report's plots as inline SVG (svg.py): PID runs, waveforms against the oracle, and the
run's timing histograms. Each comes with its numbers in words, which stay readable where a
picture does not (a text browser, a diff of two reports)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import List

from ...harness.transcript import iter_events
from .series import PidSeries, WaveRun, ideal_setpoint, pid_series, wave_runs
from .svg import Panel, Series, chart, histogram
from .timing import Timing

__all__ = ["Plot", "plot_pid", "plot_wave", "plots_for_transcript", "timing_plots"]


@dataclass
class Plot:
    title: str
    kind: str                 # pid | waveform | periods | lateness
    svg: str                  # an <svg> element
    summary: List[str]        # the numbers in words


def plot_pid(s: PidSeries, title: str) -> str:
    """Process variable and set-point (top), controller output before the ±1 clamp (bottom)."""
    return chart([
        Panel([Series(s.t, s.sp, "set-point (sp)", "#d62728", "step"),
               Series(s.t, s.pv, "process variable (pv)", "#1f77b4")], "pv, sp"),
        Panel([Series(s.t, s.cv, "output (cv)", "#2ca02c")], "cv (±1 = full drive)", hlines=(-1.0, 1.0)),
    ], title, "time (ms)")


def plot_wave(run: WaveRun, title: str) -> str:
    """Measured set-point (debug 16 ``sp``) as points over the oracle: the continuous shape the
    command asks for."""
    end = run.measured_t[-1] if run.measured_t else run.t0 + 2000 * run.period
    n = 400
    ts = [run.t0 + (end - run.t0) * i / n for i in range(n + 1)]
    return chart([Panel([Series(ts, [ideal_setpoint(run, t) for t in ts], "oracle: the shape asked for",
                                "#999999"),
                         Series(run.measured_t, run.measured_sp, "measured sp (debug 16)", "#d62728",
                                "points")], "set-point")],
                 title, "time (ms)")


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


def timing_plots(timing: Timing) -> List[Plot]:
    """The run's report-period histogram and done-lateness histogram, each with its numbers."""
    out: List[Plot] = []
    if timing.periods:
        p = sorted(timing.periods)
        title = "Report period: time between data lines of one port"
        out.append(Plot(title, "periods", histogram(p, title, "ms between lines"), [
            f"{len(p)} intervals; median {p[len(p) // 2]:g} ms, min {p[0]:g} ms, max {p[-1]:g} ms "
            "(docs/FIRMWARE-BEHAVIOUR.md#fb-reporting: the reporting engine's period)"]))
    if timing.lateness:
        late = timing.lateness
        worst = max(range(len(late)), key=lambda i: abs(late[i]))
        title = "pulse/ramp done: lateness after the requested period"
        out.append(Plot(title, "lateness", histogram(late, title, "ms after t0 + period"), [
            f"{len(late)} done line(s); lateness {min(late):g} .. {max(late):g} ms "
            f"(worst: {timing.lateness_labels[worst]}); docs/FIRMWARE-BEHAVIOUR.md#fb-waveform-end: the end "
            "comes after the period's ticks, the first 0-10 ms after the command"]))
    return out
