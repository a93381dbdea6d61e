"""``kinegym gui climber`` and ``kinegym gui arm``: the seeds' interactive programs as windows
(:mod:`kinegym.gui`). ``--frames N --screenshot F`` runs a window for N frames and saves its
last frame (recording, or a check under ``SDL_VIDEODRIVER=dummy``); ``--keys`` presses keys
at given frames (``"e@2,c@3"``). Registered on the main parser by :func:`add_parsers`; the
GUI modules load only when a window opens.
"""

from __future__ import annotations

import argparse
import os
from typing import Any

from kinegym.cli.common import EXIT_OK, Parser, UsageError, add_json, emit

__all__ = ["add_parsers", "cmd_gui"]


def _script(text: str | None) -> list[tuple[int, str]]:
    if not text:
        return []
    out = []
    for item in text.split(","):
        key, _, frame = item.strip().partition("@")
        if not key or not frame.isdigit():
            raise UsageError(f"--keys {text!r}: expected KEY@FRAME items like 'e@2,c@3'")
        out.append((int(frame), key))
    return out


def cmd_gui(args: argparse.Namespace) -> int:
    from kinegym.gui.window import GuiUnavailable, pygame_or_hint, run

    if args.frames is not None and not 1 <= args.frames <= 1_000_000:
        raise UsageError(f"--frames {args.frames}; expected 1..1000000")
    if not 1 <= args.fps <= 240:
        raise UsageError(f"--fps {args.fps}; expected 1..240")
    from kinegym.cli.play import display_available

    try:  # the toolkit first: without it the hint is what to install, not "no display"
        pygame_or_hint()
    except GuiUnavailable as err:
        raise UsageError(str(err)) from None
    headless = os.environ.get("SDL_VIDEODRIVER", "") in ("dummy", "offscreen")
    if not headless and not display_available():
        raise UsageError("no display: run it on a desktop, under xvfb-run, or with SDL_VIDEODRIVER=dummy and "
                         "--frames N --screenshot F to record")
    if headless and args.frames is None:
        raise UsageError("SDL_VIDEODRIVER=dummy shows nothing: give --frames N (and --screenshot F)")
    script = _script(args.keys)
    app = args.make_app(args)
    stats = run(app, fps=args.fps, title=args.title, script=script, max_frames=args.frames,
                screenshot=args.screenshot)
    emit(args, {"frames": stats.frames, "seconds": stats.seconds, "fps": stats.fps, "screenshot": args.screenshot},
         f"{stats.frames} frames in {stats.seconds:.1f} s ({stats.fps:.1f} fps)"
         + (f"; screenshot {args.screenshot}" if args.screenshot else ""))
    return EXIT_OK


def _climber(a: argparse.Namespace) -> Any:
    from kinegym.gui.climber import ClimberApp

    return ClimberApp(a.wall, a.robot)


def _arm(a: argparse.Namespace) -> Any:
    from kinegym.gui.arm import ArmApp

    if not (0.1 <= a.time_scale <= 20):
        raise UsageError(f"--time-scale {a.time_scale}; expected 0.1..20 x real time")
    return ArmApp(a.arm, a.time_scale)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--frames", type=int, default=None, help="close after this many frames (recording, tests)")
    p.add_argument("--screenshot", default=None, help="save the last frame here (PNG/JPEG)")
    p.add_argument("--keys", default=None, help="press keys at frames, e.g. 'e@2,c@3'")
    p.add_argument("--fps", type=float, default=30.0, help="frames per second (default 30)")
    add_json(p)
    p.set_defaults(func=cmd_gui)


def add_parsers(sub: Any) -> None:
    """Add ``gui climber`` and ``gui arm`` to the main parser's subcommands."""
    g = sub.add_parser("gui", help="interactive windows: the climber's inverse program, the arm's operational GUI")
    gs = g.add_subparsers(dest="which", required=True, parser_class=Parser)
    c = gs.add_parser("climber", help="seed 000's inverse program and localisation, live (click holes, drag the "
                                      "centre)")
    c.add_argument("--wall", default="seed_4x4", help="wall config name or YAML path")
    c.add_argument("--robot", default="climber", help="robot config name or YAML path")
    c.set_defaults(make_app=_climber, title="kinegym - climber inverse program")
    _common(c)
    a = gs.add_parser("arm", help="seed 003's operational GUI: shape, size, speed, trigger, live plots")
    a.add_argument("--arm", default="thesis_rrrr", help="arm config name or YAML path")
    a.add_argument("--time-scale", type=float, default=1.0, help="simulated seconds per real second (default 1)")
    a.set_defaults(make_app=_arm, title="kinegym - writing arm")
    _common(a)
