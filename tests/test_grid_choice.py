"""The board reader's choice among grid hypotheses (:mod:`kinegym.vision.grid_choice`) and its
trainer (:mod:`kinegym.agents.train_grid_arbiter`): the logistic fit, the choosing rule that the
reader and the trainer share, the arbiter file, and the shipped arbiter on unseen photos."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from kinegym.agents.train_grid_arbiter import _scene_hypotheses, choose, fit, main
from kinegym.configs.io import FileError
from kinegym.envs.sim.scenes_real import real_like_scene
from kinegym.vision import grid_choice
from kinegym.vision.board_reader import BoardReader, NoBoardError, VisionError
from kinegym.vision.grid_choice import FEATURES, HUE_KINDS, KINDS, PAGE_KINDS, GridArbiter, features, same_grid


def _toy(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows of FEATURES whose label follows the mean confidence (column 5) and the line coverage."""
    x = rng.normal(size=(n, len(FEATURES)))
    y = (2.0 * x[:, FEATURES.index("conf_mean")] + x[:, FEATURES.index("line_coverage")]
         + 0.3 * rng.normal(size=n)) > 0
    return x, y


def test_fit_learns_the_features_that_decide_and_is_reproducible() -> None:
    x, y = _toy(np.random.default_rng(1), 600)
    a, b = fit(x, y), fit(x, y)
    np.testing.assert_array_equal(a.weights, b.weights)
    assert a.bias == b.bias
    top = np.argsort(-np.abs(a.weights))[:2]
    assert {FEATURES[i] for i in top} == {"conf_mean", "line_coverage"}
    xt, yt = _toy(np.random.default_rng(2), 400)
    assert ((a.prob(xt) > 0.5) == yt).mean() > 0.9


def test_choose_takes_the_first_or_the_most_probable_until_one_is_accepted() -> None:
    """The rule the reader follows (and the trainer simulates): without an arbiter the first
    hypothesis; with one, hypotheses in order until one reaches ``accept``, then the most probable made."""
    k = len(FEATURES)
    arb = GridArbiter(np.zeros(k), np.ones(k), np.eye(k)[0] * 10, 0.0, 0.9)  # p rises with the first feature
    x = np.zeros((3, k))
    x[:, 0] = [-0.1, 0.05, 0.5]  # p = 0.27, 0.62, 0.99
    photos = [(x, np.array([False, True, False])), (np.zeros((0, k)), np.zeros(0, bool))]
    assert choose(photos, None) == (0, 0.5)  # the first is wrong; a photo without hypotheses is not right
    assert choose(photos, arb, 1.0) == (0, 1.5)  # all made, the most probable (the third) is wrong
    assert choose(photos, arb, 0.6) == (1, 1.0)  # the second reaches 0.6: the third is never made


def test_an_arbiter_file_round_trips_and_bad_files_are_named(tmp_path: Path) -> None:
    x, y = _toy(np.random.default_rng(3), 200)
    arb = fit(x, y)
    arb.accept, arb.info = 0.8, {"note": "test"}
    path = tmp_path / "a.json"
    path.write_text(arb.to_json())
    back = GridArbiter.load(path)
    np.testing.assert_array_equal(back.prob(x), arb.prob(x))
    assert back.accept == 0.8 and back.info == {"note": "test"}
    obj = json.loads(arb.to_json())
    for name, change, expect in (("junk.json", None, "junk.json: not a grid arbiter"),
                                 ("old.json", {"features": ["conf_mean"]}, "over features \\['conf_mean'\\]"),
                                 ("short.json", {"weights": [1.0]}, "with shapes"),
                                 ("accept.json", {"accept": 0.0}, "accept in \\(0, 1\\]"),
                                 ("part.json", {"bias": None}, "lacks or mistypes")):
        p = tmp_path / name
        p.write_text("{not json" if change is None else json.dumps({**obj, **change}))
        with pytest.raises(VisionError, match=expect):
            GridArbiter.load(p)
    with pytest.raises(FileError, match="missing.json: no such file"):
        BoardReader(arbiter=str(tmp_path / "missing.json"))


def test_hypotheses_are_made_once_per_grid_and_traced() -> None:
    """A real-like photo where several hypotheses exist: each grid is made once, the reader's
    trace lists the kinds it made with their probabilities, and what it returns is the most
    probable of them."""
    sc = real_like_scene(20_001)
    hyps = BoardReader(size=3, arbiter=None).hypotheses(sc.image)
    order = KINDS + PAGE_KINDS + HUE_KINDS
    assert len(hyps) >= 2 and [h.kind for h in hyps] == [k for k in order if k in {h.kind for h in hyps}]
    assert not any(same_grid(a, b) for i, a in enumerate(hyps) for b in hyps[i + 1:])
    assert all(features(h).shape == (len(FEATURES),) and np.isfinite(features(h)).all() for h in hyps)
    trace: dict[str, object] = {}
    reading = BoardReader(size=3).read(sc.image, trace)
    made = trace["hypotheses"]
    assert made and all(kind in order and 0.0 <= p <= 1.0 for kind, p in made)  # type: ignore[union-attr]
    best = max(made, key=lambda kp: kp[1])  # type: ignore[arg-type, union-attr]
    assert trace["kind"] == best[0]  # the kind read, as read-board and the debug picture say it
    assert reading.cells.shape == (3, 3) and trace["cell_inputs"] is not None
    chosen = next(h for h in hyps if h.kind == best[0])  # the same grids, made by a reader without an arbiter
    assert chosen.scale < 1.0  # a 1,280 px photo, read on an 800 px working copy
    np.testing.assert_allclose(reading.homography, np.diag([1 / chosen.scale, 1 / chosen.scale, 1.0]) @ chosen.H)
    np.testing.assert_array_equal(reading.cells, chosen.probs.argmax(-1))


def test_no_grid_names_every_hypothesis_tried() -> None:
    blank = np.full((480, 640, 3), 235, np.uint8)
    trace: dict[str, object] = {}
    with pytest.raises(NoBoardError) as err:
        BoardReader(size=3).read(blank, trace)
    assert "straight lines:" in err.value.reason and "hash 22%:" in err.value.reason
    assert trace["hypotheses"] == []


def test_the_shipped_arbiter_reads_more_unseen_boards_than_the_first_grid_found() -> None:
    """40 real-like photos from seeds neither trained on (3,000,000 on) nor benchmarked (20,000 on),
    with every hypothesis made: the shipped arbiter's choice reads more boards right than the
    first grid found, and never fewer than it by more than one photo on the hard rendered boards
    where the straight field is right."""
    real = [_scene_hypotheses(("real-like", 5_000_000 + i, ())) for i in range(40)]
    arbiter = BoardReader().arbiter
    assert arbiter is not None
    first, chosen = choose(real, None)[0], choose(real, arbiter, arbiter.accept)[0]
    assert chosen > first, (chosen, first)
    hard = [_scene_hypotheses(("hard", 5_100_000 + i, ())) for i in range(12)]
    assert choose(hard, arbiter, arbiter.accept)[0] >= choose(hard, None)[0] - 1


def test_the_training_entry_point_writes_an_arbiter_the_reader_uses(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    out, data = tmp_path / "arb.json", tmp_path / "hyps.npz"
    assert main(["--real-like", "10", "--hard", "3", "--workers", "1", "--data", str(data), "--out", str(out)]) == 0
    report = GridArbiter.load(out).info
    assert report["photos"] == {"real_like": 10, "hard": 3, "held_out": 3} and "oracle" in str(report)
    assert data.exists() and "wrote" in capsys.readouterr().out
    again = tmp_path / "again.json"
    assert main(["--real-like", "10", "--hard", "3", "--workers", "1", "--data", str(data), "--out", str(again)]) == 0
    assert again.read_text() == out.read_text()  # the same photos, read back from --data: the same arbiter
    sc = real_like_scene(5_000_000)
    try:
        assert BoardReader(size=3, arbiter=str(out)).read(sc.image).cells.shape == (3, 3)
    except NoBoardError:
        pass
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(FileError, match="bad.npz: not a hypotheses file"):
        main(["--real-like", "2", "--hard", "0", "--workers", "1", "--data", str(tmp_path / "bad.npz")])
    with pytest.raises(SystemExit):
        main(["--l2", "-1"])
    assert "--l2 -1.0; expected 0..10" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--model", str(tmp_path / "none.npz")])
    assert "none.npz: no such file; expected a cell model" in capsys.readouterr().err


def test_the_arbiter_learns_the_calls_of_the_models_it_is_given() -> None:
    """``--model``: the hypotheses' features come from the cells as the given model reads them
    (the shipped ensemble's second member alone here), not from the shipped ensemble's."""
    from kinegym.vision.cell_model import SHIPPED_MODELS

    own = [_scene_hypotheses(("real-like", 5_000_000 + i, (str(SHIPPED_MODELS[1]),)))[0] for i in range(3)]
    shipped = [_scene_hypotheses(("real-like", 5_000_000 + i, ()))[0] for i in range(3)]
    assert [a.shape for a in own] == [b.shape for b in shipped]
    assert any(not np.array_equal(a, b) for a, b in zip(own, shipped))


def test_a_straight_field_framed_on_one_side_gives_way_to_the_hash(monkeypatch: pytest.MonkeyPatch) -> None:
    """Real-like photo 20,766 (notebook paper, the '#''s top row line gone over twice): the straight
    finder took that line for a border, the column lines barely running past it, and read a field
    shifted down by a cell, framed on the top only; the arbiter, which does not see the frame, gave
    it 0.93 and it was taken at once. Framed on one side only it is given at most
    ONE_SIDE_FRAMED_P, the '#' readings are made, and the right one (p 0.92) is read."""
    sc = real_like_scene(20_766)
    reader = BoardReader(size=3)
    made = reader.hypotheses(sc.image)
    straight = next(h for h in made if h.kind == "straight")
    assert straight.frame == (False, False, True, False)
    assert straight.p == grid_choice.ONE_SIDE_FRAMED_P < float(reader.arbiter.prob(features(straight)[None])[0])
    assert all(h.p == float(reader.arbiter.prob(features(h)[None])[0]) for h in made if sum(h.frame) != 1)
    assert np.array_equal(reader.read(sc.image).cells, sc.cells)
    monkeypatch.setattr(grid_choice, "ONE_SIDE_FRAMED_P", 1.0)
    wrong = reader.read(sc.image)
    assert not np.array_equal(wrong.cells, sc.cells) and wrong.frame == (False, False, True, False)
