"""The bench scripts' own options, run small: the figures are the benches' business, not a test's.

* ``bench/bench_envs.py --budget``: where a HoleClimb step's time goes, part by part. The parts
  are timed where the env calls them; a renamed method would leave a part at zero or break the
  sums, and the parts, each a difference of nested timers, are never negative and add up to no
  more than the steps' own time.
* ``bench/bench_vision.py --why``: why each board read wrong was wrong, against the scene's own
  crossings (the grid not found, another grid chosen, or which cells).
* ``bench/bench_vision.py --real-like-from``: the real-like set drawn from other seeds (the
  reader was tuned on 20,000 on; 40,000 on is a held-out draw) reads the seeds asked for.
* ``bench/photo_conditions.py``: every held-out condition row makes a photo the reader can be given.
"""

from __future__ import annotations

import numpy as np


def test_the_parts_of_a_step_are_all_found_and_add_up(bench_envs) -> None:
    rate, n, rows = bench_envs.step_parts(0.5, "kinegym/HoleClimbMemoryHints-v0", warm=0.2, wall_pool=3)
    assert n > 50 and rate > 0
    parts = dict(rows)
    assert len(parts) == 10
    assert all(v >= -1e-6 for v in parts.values()), parts
    for name in ("the gait kernel judging a new stance's 24 moves", "the move (kinematic climber, judged by the mask)",
                 "the localiser tracking the encoders", "the observation",
                 "resets: a new wall, proved climbable by the planner"):
        assert parts[name] > 0, name
    assert sum(parts.values()) <= 1e6 / rate * 1.001  # the bench's own action choice lies outside the parts


def test_the_budget_table_prints(bench_envs, capsys) -> None:
    bench_envs.step_budget(0.2)
    out = capsys.readouterr().out
    assert "| part of a step, us per step (x the budget) | HoleClimb-v0, a fresh wall every reset |" in out
    assert "| **a whole step** |" in out and "| the gait kernel judging a new stance's 24 moves |" in out


def test_the_real_like_set_starts_at_the_seed_asked_for(bench_vision, capsys, monkeypatch) -> None:
    from kinegym.envs.sim import scenes_real

    drawn: list[int] = []
    real = scenes_real.real_like_scene
    monkeypatch.setattr(scenes_real, "real_like_scene", lambda seed: drawn.append(seed) or real(seed))
    bench_vision.real_like(2, 40_000)
    out = capsys.readouterr().out
    assert drawn == [40_000, 40_001]
    assert "2 real-like photos (3 x 3, seeds 40,000 on)" in out
    assert "| all | 2 |" in out


def test_why_a_board_read_wrong_was_wrong(bench_vision, capsys) -> None:
    """``--why``: a reading under the scene's own '#' with three cells changed names each error;
    the same reading one cell over is another grid, made or not; no reading is a refusal."""
    import dataclasses

    import numpy as np

    from kinegym.envs.sim.scenes_real import real_like_scene
    from kinegym.vision.board_reader import BoardReader

    reader = BoardReader(size=3)
    sc = real_like_scene(20_000)
    reading = reader.read(sc.image)
    assert sc.text() == reading.text() == "X..|.X.|OOX"
    assert bench_vision.why_wrong(reader, sc, reading) == ("the '#' chosen, cells read wrong", [])
    cells = reading.cells.copy()
    cells[0, 0], cells[0, 1], cells[2, 0] = 0, 2, 1  # X missed, an O invented, an O read as X
    assert bench_vision.why_wrong(reader, sc, dataclasses.replace(reading, cells=cells)) == (
        "the '#' chosen, cells read wrong",
        [("mark read empty", "corner"), ("empty read as a mark", "edge"), ("X and O swapped", "corner")])
    one_over = np.array([[1, 0, 1.0], [0, 1, 0], [0, 0, 1]])  # the lattice one cell to the right
    shifted = dataclasses.replace(reading, homography=reading.homography @ one_over)
    assert bench_vision.why_wrong(reader, sc, shifted) == ("the '#' made, another grid chosen", [])

    class NoHypotheses:
        def hypotheses(self, image: object) -> list:
            return []

    assert bench_vision.why_wrong(NoHypotheses(), sc, shifted) == ("no grid made is the drawn '#'", [])
    assert bench_vision.why_wrong(reader, sc, None) == ("refused", [])
    bench_vision.print_why([("refused", []), ("the '#' chosen, cells read wrong", [("mark read empty", "edge")])], 10)
    out = capsys.readouterr().out
    assert "Why 2 of 10 real-like boards read wrong" in out
    assert "| refused | 1 | 50% |" in out and "| mark read empty | 0 | 1 | 0 |" in out


def test_every_held_out_condition_makes_a_photo_the_reader_can_be_given(photo_conditions) -> None:
    """``bench/photo_conditions.py``: each row's transform of a real photo gives an RGB uint8 photo of
    at least 300 px a side, the same for the same photo index (a seeded condition), and another photo
    than the one given (the graph paper, the pens, the reflection, the ghosts change it); each row's
    readings include the label itself unless the row turns or mirrors the photo."""
    import json
    from pathlib import Path

    from kinegym.vision.image_io import read_image

    data = Path(__file__).resolve().parent / "data" / "real"
    name = sorted(json.loads((data / "labels.json").read_text())["boards"])[4]  # image13: marks in 6 cells
    img = read_image(data / name)
    rows = photo_conditions.photo_conditions()
    assert len({label for label, _, _ in rows}) == len(rows) >= 40
    for label, transform, readings in rows:
        out = transform(img, 4)
        assert out.dtype == np.uint8 and out.ndim == 3 and out.shape[2] == 3 and min(out.shape[:2]) >= 300, label
        if label != "as taken, 577 x 433":
            assert out.shape != img.shape or not np.array_equal(out, img), label
        if label.startswith(("on graph", "a whiteboard", "ghosts", "every stroke", "group")):
            assert np.array_equal(out, transform(img, 4)), label
        assert ("XXO|XO.|O.." in readings("XXO|XO.|O..")) == (label != "mirrored"), label
