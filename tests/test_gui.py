"""The interactive windows, driven by synthetic events through the real pygame loop
(``SDL_VIDEODRIVER=dummy``): state and a screenshot are checked."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
pytest.importorskip("pygame")


def _px(app, xy):  # type: ignore[no-untyped-def]
    p = app.canvas.px(np.asarray(xy))
    return int(p[0]), int(p[1])


def test_climber_window_reproduces_the_seed_and_follows_clicks(tmp_path: Path) -> None:
    import pygame as pg

    from kinegym.gui.climber import SEED_CENTRE, ClimberApp
    from kinegym.gui.window import mouse_events, run
    from kinegym.kinematics.climber import inverse_program

    app = ClimberApp()
    hole = app.wall.xy[5].copy()  # hole (2, 2)
    centre_px = _px(app, [9.0, 9.0])
    shot = tmp_path / "climber.png"
    script = [(1, "e"), (2, "h"), (3, "2"), (4, mouse_events(pg, "down", _px(app, hole))),
              (5, mouse_events(pg, "up", _px(app, hole))), (6, "c"), (7, mouse_events(pg, "down", centre_px)),
              (8, mouse_events(pg, "move", (centre_px[0] + 8, centre_px[1]), held=True)),
              (9, mouse_events(pg, "up", (centre_px[0] + 8, centre_px[1])))]
    stats = run(app, fps=120, script=script, max_frames=12, screenshot=shot)
    assert stats.frames == 12
    assert np.array_equal(app.holes[1], hole) and app.arm == 2  # arm 2 took the hole, arm 3 is next
    want = app._world((centre_px[0] + 8, centre_px[1]))
    assert np.allclose(app.centre, want) and not np.allclose(app.centre, SEED_CENTRE)
    assert app.q is not None
    assert np.allclose(app.q, inverse_program(app.holes, app.centre, 0.0, app.geom))
    from kinegym.vision.image_io import read_image

    img = read_image(shot)
    assert img.shape == (app.size[1], app.size[0], 3) and img.std() > 20


def test_climber_window_shows_the_seed_numbers() -> None:
    from kinegym.gui.climber import ClimberApp, centre_angles
    from kinegym.gui.widgets import Event
    from kinegym.gui.window import drive

    app = ClimberApp()
    drive(app, [Event("key", key="e")])
    text = "\n".join(app.readout.lines)
    assert "angulo1 =  -69.4851  101.1454" in text and "xR = 6.6289 cm" in text
    th = np.degrees(centre_angles(app.holes, app.centre))
    assert abs(th.sum() - 360.0) < 1e-9  # the centre lies inside the hole triangle
    drive(app, [Event("key", key="b")])  # the other elbows: still the same hands
    from kinegym.kinematics.climber import hand_positions

    assert np.allclose(hand_positions(app.q, app.geom), app.holes - app.centre)
    drive(app, [Event("key", key="c"), Event("down", _px(app, [58.0, 58.0]))])
    assert app.q is None and "unreachable" in "\n".join(app.readout.lines)


def test_gui_cli_records_and_refuses_without_a_display(tmp_path: Path) -> None:
    shot = tmp_path / "g.png"
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy"}
    r = subprocess.run([sys.executable, "-m", "kinegym", "gui", "climber", "--frames", "5", "--keys", "e@1",
                        "--screenshot", str(shot)], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0 and shot.stat().st_size > 10_000, r.stderr
    r = subprocess.run([sys.executable, "-m", "kinegym", "gui", "climber"], capture_output=True, text=True,
                       env=env, timeout=120)
    assert r.returncode == 2 and "--frames" in r.stderr and "Traceback" not in r.stderr


def test_no_gui_code_in_the_light_imports() -> None:
    code = ("import sys, kinegym, kinegym.cli, kinegym.envs.hole_climb; "
            "bad = [m for m in sys.modules if m.startswith(('pygame', 'kinegym.gui'))]; print(bad); "
            "sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


def test_arm_window_draws_live_and_stops(tmp_path: Path) -> None:
    from kinegym.gui.arm import ArmApp
    from kinegym.gui.widgets import Event
    from kinegym.gui.window import drive, run

    app = ArmApp(time_scale=20.0)
    drive(app, [Event("key", key="l"), Event("key", key="]"), Event("key", key="]"), Event("key", key="]"),
                Event("key", key="space")])
    assert app.drawing and app.shape.value == "lines" and app.speed.value == 5
    assert app.sim.canvas.ink().max() == 0 or app.run.i > 0
    for _ in range(2000):
        if not app.drawing:
            break
        app.update(1 / 30)
    assert not app.drawing and app.status.startswith("done: lines")
    assert app.sim.canvas.ink().max() > 0.3  # the lines are on the board
    # a big O (past the cell, as the thesis's 10 cm slider) is drawn about the field's centre
    drive(app, [Event("key", key="o")] + [Event("key", key="=")] * 8)
    assert app.size_cm.value == 7.0 and len(app.strokes()) == 1
    # trigger, then stop midway: the run ends where the arm is
    shot = tmp_path / "arm.png"
    stats = run(app, fps=60, script=[(1, "space"), (12, "backspace")], max_frames=16, screenshot=shot)
    assert stats.frames == 16 and app.run is None and app.status.startswith("stopped after")
    from kinegym.vision.image_io import read_image

    img = read_image(shot)
    assert img.shape == (app.size[1], app.size[0], 3) and img.std() > 20


def test_play_window_controls_symbol_play_draw_and_stop(monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    """The game window driven by scripted events: choose O, Play, the arm (X) draws its move
    (frames shown as it draws), the person draws an O with the mouse in a free cell, Enter;
    at the next turn Stop ends the game and Esc the program."""
    import json

    import pygame as pg

    from kinegym.cli import main
    from kinegym.cli import play as P

    monkeypatch.setattr(P, "display_available", lambda: True)
    state = {"phase": 0, "person": None, "arm_frames": 0}
    orig_init, orig_frame = P.WindowPerson.__init__, P.WindowPerson._arm_frame

    def init(self, env, symbol="X"):  # type: ignore[no-untyped-def]
        orig_init(self, env, symbol)
        state["person"] = self

    def arm_frame(self, frame):  # type: ignore[no-untyped-def]
        state["arm_frames"] += 1
        return orig_frame(self, frame)

    monkeypatch.setattr(P.WindowPerson, "__init__", init)
    monkeypatch.setattr(P.WindowPerson, "_arm_frame", arm_frame)
    queue: list = []

    def cell_px(person, cell):  # type: ignore[no-untyped-def]
        lay, n = person.env.layout, person.env.n
        r, c = divmod(cell, n)
        centre = np.asarray(lay.field_origin) + [(c + 0.5) * lay.cell, (n - 1 - r + 0.5) * lay.cell]
        x0, _, _, y1 = person.box
        p = centre + np.asarray(person.env.sim.layout.canvas_origin)
        return int((p[0] - x0) * 20.0), int((y1 - p[1]) * 20.0)

    def wait():  # type: ignore[no-untyped-def]
        if not queue:
            person = state["person"]
            if state["phase"] == 0:  # the lobby: choose O, Play
                queue.extend([P_key("o"), P_key("p")])
            elif state["phase"] == 1:  # first turn: draw an O in a free cell
                free = next(i for i in range(9) if person.env.true_board.is_legal(i))
                u, v = cell_px(person, free)
                state["cell"] = free
                ring = [(u + int(15 * np.cos(a)), v + int(15 * np.sin(a))) for a in np.linspace(0, 6.4, 24)]
                queue.append(pg.event.Event(pg.MOUSEBUTTONDOWN, pos=ring[0], button=1))
                queue.extend(pg.event.Event(pg.MOUSEMOTION, pos=p, rel=(0, 0), buttons=(1, 0, 0)) for p in ring)
                queue.extend([pg.event.Event(pg.MOUSEBUTTONUP, pos=ring[-1], button=1), P_key("return")])
            elif state["phase"] == 2:  # second turn: Stop
                queue.append(P_key("s"))
            else:  # back in the lobby: Esc
                queue.append(P_key("escape"))
            state["phase"] += 1
        return queue.pop(0)

    def P_key(name):  # type: ignore[no-untyped-def]
        return pg.event.Event(pg.KEYDOWN, key=pg.key.key_code(name), mod=0, unicode="", scancode=0)

    monkeypatch.setattr(pg.event, "wait", wait)
    monkeypatch.setattr(pg.event, "get", lambda *a, **k: [])
    assert main(["play", "--board", "3", "--fast", "--no-erase", "--json"]) == 0
    out = capsys.readouterr().out
    res = json.loads(out.strip().splitlines()[-1])
    assert res["games"][0]["symbol"] == "O" and res["games"][0]["winner"] == "stopped"
    assert "game stopped" in out and "you left the game" in out
    person = state["person"]
    assert state["arm_frames"] > 0  # the arm's move was shown as it drew
    assert person.env.true_board.cells()[state["cell"] // 3][state["cell"] % 3] == 2  # the person's O
    assert person.last.shape[1] == person.fw + P._PANEL and person.last.std() > 20


def test_a_missing_toolkit_is_the_install_hint(monkeypatch: pytest.MonkeyPatch) -> None:
    from kinegym.gui.window import GuiUnavailable, pygame_or_hint

    monkeypatch.setitem(sys.modules, "pygame", None)  # import pygame -> ImportError
    with pytest.raises(GuiUnavailable, match=r"pip install \"kinegym\[human\]\""):
        pygame_or_hint()
