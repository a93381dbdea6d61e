"""Frame rate of kinegym's windows while they work (the arm drawing live, the climber app).

Run::

    SDL_VIDEODRIVER=dummy taskset -c 0 python bench/bench_gui.py [--frames 300]

The real pygame loop (:func:`kinegym.gui.window.run`) runs uncapped; each frame handles the
events, steps the simulation by one frame's worth of simulated time (``1/30`` s x the time
scale), renders and blits. Reported: the median and p95 frame time and the frame rate they
allow, for the arm GUI drawing an O at real time and at 2x, and the climber app (the anchor,
measured in the same run). Target (issue 20): >= 30 fps while the arm draws.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


def _measure(app, frames: int, script) -> tuple[float, float, int]:  # type: ignore[no-untyped-def]
    from kinegym.gui.window import run

    stats = run(app, fps=10_000, script=script, max_frames=frames)
    ms = np.array(stats.frame_ms[5:])
    return float(np.median(ms)), float(np.percentile(ms, 95)), getattr(app, "frames_while_drawing", len(ms))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=300)
    args = ap.parse_args()
    from kinegym.gui.arm import ArmApp
    from kinegym.gui.climber import ClimberApp

    print("| window | frames | median ms | p95 ms | fps (median) | x the climber app |")
    print("|---|---|---|---|---|---|")
    anchor, p95, _ = _measure(ClimberApp(), args.frames, [(1, "e")])
    rows = [("climber app (anchor)", anchor, p95, args.frames)]
    for scale in (1.0, 2.0):
        app = ArmApp(time_scale=scale)
        med, p, drawing = _measure(app, args.frames, [(1, "o"), (2, "space")])
        rows.append((f"arm GUI drawing an O, x{scale:g} real time", med, p, drawing))
    for name, med, p, n in rows:
        print(f"| {name} | {n} | {med:.1f} | {p:.1f} | {1000 / med:.0f} | {med / anchor:.2f} |", flush=True)


if __name__ == "__main__":
    main()
