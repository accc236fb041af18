"""Charts as inline SVG text: line, step and point series on panels sharing one time axis, and
histograms. The report draws its own (a few milliseconds for a whole run) instead of rendering
PNGs with matplotlib (most of a second each), and the pictures scale with the page."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from html import escape
from typing import List, Sequence, Tuple

__all__ = ["Series", "Panel", "chart", "histogram", "nice_ticks"]

WIDTH = 640
LEFT, RIGHT, TOP, BOTTOM = 58, 12, 36, 34      # y tick labels, title + legend, x ticks + x label
GAP = 22                                      # between panels: room for the legend
MAX_POINTS = 1200                             # per series; more are thinned (the line looks the same)


@dataclass
class Series:
    xs: Sequence[float]
    ys: Sequence[float]
    label: str
    color: str
    style: str = "line"       # line | step (held until the next sample) | points


@dataclass
class Panel:
    series: List[Series]
    ylabel: str
    hlines: Sequence[float] = field(default_factory=tuple)   # dashed reference lines (e.g. the ±1 clamp)


def nice_ticks(lo: float, hi: float, n: int = 5) -> List[float]:
    """Round tick values covering [lo, hi]: steps of 1, 2 or 5 times a power of ten."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return [0.0]
    if hi <= lo:
        return [lo]
    raw = (hi - lo) / max(1, n)
    mag = 10 ** math.floor(math.log10(raw))
    # The step of the four candidates whose tick count is nearest the wish.
    step = min((m * mag for m in (1, 2, 5, 10)), key=lambda st: abs((hi - lo) / st - n))
    first = math.ceil(lo / step - 1e-9) * step
    out, k = [], 0
    while first + k * step <= hi + step * 1e-9:
        out.append(round(first + k * step, 12))
        k += 1
    return out


def _fmt(v: float) -> str:
    return f"{v:g}" if abs(v) < 1e6 else f"{v:.3g}"


def _finite(xs: Sequence[float]) -> List[float]:
    return [x for x in xs if isinstance(x, (int, float)) and math.isfinite(x)]


def _span(values: List[float], pad: float = 0.0) -> Tuple[float, float]:
    if not values:
        return 0.0, 1.0
    lo, hi = min(values), max(values)
    if hi == lo:
        return lo - 1.0, hi + 1.0
    extra = (hi - lo) * pad
    return lo - extra, hi + extra


def _thin(xs: Sequence[float], ys: Sequence[float]) -> List[Tuple[float, float]]:
    pts = list(zip(xs, ys))
    if len(pts) <= MAX_POINTS:
        return pts
    step = len(pts) / MAX_POINTS
    return [pts[int(i * step)] for i in range(MAX_POINTS)] + [pts[-1]]


def _path(series: Series, sx, sy) -> str:   # type: ignore[no-untyped-def]
    """The series as one SVG path; a gap (NaN) starts a new stroke."""
    d: List[str] = []
    pen_up = True
    for x, y in _thin(series.xs, series.ys):
        if not (math.isfinite(x) and math.isfinite(y)):
            pen_up = True
            continue
        px, py = sx(x), sy(y)
        if pen_up:
            d.append(f"M{px:.1f} {py:.1f}")
        elif series.style == "step":
            d.append(f"H{px:.1f}V{py:.1f}")
        else:
            d.append(f"L{px:.1f} {py:.1f}")
        pen_up = False
    return "".join(d)


def _frame(x0: float, y0: float, w: float, h: float, xt: List[float], yt: List[float], sx, sy,  # type: ignore
           x_labels: bool, ylabel: str) -> List[str]:
    out = [f'<rect x="{x0}" y="{y0}" width="{w}" height="{h}" fill="none" stroke="#888"/>']
    for t in yt:
        y = sy(t)
        out.append(f'<line x1="{x0}" x2="{x0 + w}" y1="{y:.1f}" y2="{y:.1f}" stroke="#eee"/>'
                   f'<text x="{x0 - 4}" y="{y + 3.5:.1f}" text-anchor="end">{_fmt(t)}</text>')
    for t in xt:
        x = sx(t)
        out.append(f'<line x1="{x:.1f}" x2="{x:.1f}" y1="{y0 + h}" y2="{y0 + h + 4}" stroke="#888"/>')
        if x_labels:
            out.append(f'<text x="{x:.1f}" y="{y0 + h + 15}" text-anchor="middle">{_fmt(t)}</text>')
    cy = y0 + h / 2
    out.append(f'<text x="12" y="{cy:.1f}" text-anchor="middle" transform="rotate(-90 12 {cy:.1f})">'
               f"{escape(ylabel)}</text>")
    return out


def _legend(series: List[Series], right: float, y: float) -> List[str]:
    out, x = [], right - 6
    for s in reversed([s for s in series if s.label]):
        width = 7 * len(s.label) + 22
        x -= width
        mark = (f'<circle cx="{x + 8}" cy="{y - 4}" r="2.5" fill="{s.color}"/>' if s.style == "points" else
                f'<line x1="{x}" x2="{x + 16}" y1="{y - 4}" y2="{y - 4}" stroke="{s.color}" '
                'stroke-width="2"/>')
        out.append(f'{mark}<text x="{x + 20}" y="{y}">{escape(s.label)}</text>')
    return out


def _svg(width: int, height: int, title: str, body: List[str]) -> str:
    return (f'<svg class=chart viewBox="0 0 {width} {height}" width="{width}" height="{height}" '
            'xmlns="http://www.w3.org/2000/svg" font-family="sans-serif" font-size="11" role="img">'
            f"<title>{escape(title)}</title>"
            f'<text x="{width / 2}" y="14" text-anchor="middle" font-size="12">{escape(title)}</text>'
            + "".join(body) + "</svg>")


def chart(panels: List[Panel], title: str, xlabel: str, width: int = WIDTH, panel_height: int = 170) -> str:
    """Panels stacked over one x axis (the last panel carries the x labels)."""
    xs = _finite([x for p in panels for s in p.series for x in s.xs])
    x_lo, x_hi = _span(xs)
    w = width - LEFT - RIGHT
    height = TOP + len(panels) * (panel_height + GAP) - GAP + BOTTOM
    body: List[str] = []

    def sx(x: float) -> float:
        return LEFT + (x - x_lo) / (x_hi - x_lo) * w

    xt = nice_ticks(x_lo, x_hi, 8)
    for i, panel in enumerate(panels):
        y0 = TOP + i * (panel_height + GAP)
        ys = _finite([y for s in panel.series for y in s.ys] + list(panel.hlines))
        y_lo, y_hi = _span(ys, 0.05)

        def sy(y: float, y0: float = y0, y_lo: float = y_lo, y_hi: float = y_hi) -> float:
            return y0 + panel_height - (y - y_lo) / (y_hi - y_lo) * panel_height

        body += _frame(LEFT, y0, w, panel_height, xt, nice_ticks(y_lo, y_hi, 4), sx, sy,
                       i == len(panels) - 1, panel.ylabel)
        for h in panel.hlines:
            body.append(f'<line x1="{LEFT}" x2="{LEFT + w}" y1="{sy(h):.1f}" y2="{sy(h):.1f}" stroke="#999" '
                        'stroke-dasharray="4 3"/>')
        for s in panel.series:
            if s.style == "points":
                body.append(f'<g fill="{s.color}">' + "".join(
                    f'<circle cx="{sx(x):.1f}" cy="{sy(y):.1f}" r="1.8"/>' for x, y in _thin(s.xs, s.ys)
                    if math.isfinite(x) and math.isfinite(y)) + "</g>")
            else:
                body.append(f'<path d="{_path(s, sx, sy)}" fill="none" stroke="{s.color}" '
                            'stroke-width="1.4"/>')
        body += _legend(panel.series, LEFT + w, y0 - 5)   # above the frame: never over a line
    body.append(f'<text x="{LEFT + w / 2}" y="{height - 4}" text-anchor="middle">{escape(xlabel)}</text>')
    return _svg(width, height, title, body)


def histogram(values: Sequence[float], title: str, xlabel: str, width: int = WIDTH, height: int = 210) -> str:
    vals = _finite(values)
    lo, hi = _span(vals)
    bins = min(40, max(5, len(vals) // 5))
    counts = [0] * bins
    for v in vals:
        counts[min(bins - 1, int((v - lo) / (hi - lo) * bins))] += 1
    w, h = width - LEFT - RIGHT, height - TOP - BOTTOM
    top = max(counts) if counts and max(counts) else 1

    def sx(x: float) -> float:
        return LEFT + (x - lo) / (hi - lo) * w

    def sy(c: float) -> float:
        return TOP + h - c / top * h

    body = _frame(LEFT, TOP, w, h, nice_ticks(lo, hi, 8), nice_ticks(0, top, 4), sx, sy, True, "count")
    bw = w / bins
    body.append('<g fill="#1f77b4">' + "".join(
        f'<rect x="{LEFT + i * bw + 0.5:.1f}" y="{sy(c):.1f}" width="{max(bw - 1, 0.5):.1f}" '
        f'height="{TOP + h - sy(c):.1f}"><title>{c}</title></rect>'
        for i, c in enumerate(counts) if c) + "</g>")
    body.append(f'<text x="{LEFT + w / 2}" y="{height - 4}" text-anchor="middle">{escape(xlabel)}</text>')
    return _svg(width, height, title, body)
