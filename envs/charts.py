"""Charts people read: learning curves, sensor studies, precision runs and step responses,
drawn with matplotlib (the Agg backend: no display, no GUI toolkit).

:func:`line_chart` returns the chart as an RGB array (``save_rgb`` writes it, panels stack with
numpy), so a chart and an env frame are handled alike; the axes get matplotlib's tick
locator (round values), the legend is placed where it covers the least data, and units belong
in the axis labels. Env frames and the live GUI panels stay OpenCV drawings
(:mod:`kinegym.envs.draw`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["line_chart"]


#: A series with at most this many points is drawn with markers whatever ``markers`` says.
FEW_POINTS = 30


def line_chart(series: dict[str, tuple[Sequence[float], Sequence[float]]], title: str, xlabel: str,
               ylabel: str, size: tuple[int, int] = (720, 420), log_x: bool = False,
               ylim: tuple[float, float] | None = None, markers: bool = True) -> np.ndarray:
    """A line chart of named ``(x, y)`` series as an RGB array ``size`` = (width, height) px:
    one colour per series (with markers unless ``markers=False``; a series of at most
    :data:`FEW_POINTS` points always has them: one point alone draws no line), a legend (when there is
    more than one series), ``title``, axis labels (give units: "time (s)"), a log x axis with
    ``log_x``, fixed y limits with ``ylim``. Non-finite y values leave gaps."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    w, h = size
    dpi = 100
    fig = Figure(figsize=(w / dpi, h / dpi), dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    small = h < 260
    for name, (x, y) in series.items():
        y_arr = np.asarray(y, float)
        ax.plot(np.asarray(x, float), np.where(np.isfinite(y_arr), y_arr, np.nan), label=name, linewidth=1.6,
                marker="o" if markers or len(y_arr) <= FEW_POINTS else None, markersize=4)
    if log_x:
        ax.set_xscale("log")
        xs = sorted({float(v) for x, _ in series.values() for v in np.asarray(x, float).ravel() if v > 0})
        if 1 < len(xs) <= 8:  # a few measured points: label exactly those, not the decades
            ax.set_xticks(xs, [f"{v:g}" for v in xs])
            ax.minorticks_off()
    if ylim is not None:
        lo, hi = ylim
        pad = 0.02 * (hi - lo)  # markers on the limits stay whole
        ax.set_ylim(lo - pad, hi + pad)
    ax.set_xlabel(xlabel, fontsize=8 if small else 10)
    ax.set_ylabel(ylabel, fontsize=8 if small else 10)
    if title:
        ax.set_title(title, fontsize=9 if small else 11)
    ax.tick_params(labelsize=7 if small else 9)
    ax.grid(True, color="0.9")
    if len(series) > 3:  # many series: the legend goes below the axes, never over the data
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=min(3, len(series)),
                  fontsize=7 if small else 8, frameon=False)
    elif len(series) > 1:
        ax.legend(loc="best", fontsize=7 if small else 9, framealpha=0.85)
    fig.tight_layout(pad=0.4)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()
