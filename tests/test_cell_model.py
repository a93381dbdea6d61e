"""The learned cell classifier: what it sees of a cell, its training (on synthetic cells and
through the real training entry point), its file, and the shipped model on photos it was not
trained on - more cells right than the hand rule, with calibrated confidences."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from kinegym.agents.train_cells import (
    CellData,
    collect,
    expected_calibration_error,
    fit,
    fit_temperature,
    grid_is_right,
    load_or_collect,
    main,
    recalibrate,
)
from kinegym.configs.io import FileError
from kinegym.envs.sim.scenes_real import real_like_scene
from kinegym.vision.board_reader import BoardReader, NoBoardError, VisionError
from kinegym.vision.cell_model import (
    N_CHANNELS,
    N_INPUTS,
    SHIPPED_MODELS,
    WIN,
    CellEnsemble,
    CellModel,
    cell_inputs,
    channels,
)
from kinegym.vision.cells import _probabilities, board_features

S, O = 40, 20  # rectified cell and margin (px), as the reader uses


def _board(rng: np.random.Generator, n: int = 3) -> tuple[np.ndarray, np.ndarray, float]:
    """A rectified ink map of ``n`` x ``n`` cells with random X / O / empty, pens of random
    darkness and width, and faint noise: ``(map, truth, line darkness)``."""
    side = n * S + 2 * O
    rect = np.zeros((side, side), np.float32)
    truth = rng.integers(0, 3, (n, n))
    for r in range(n):
        for c in range(n):
            cx, cy = O + c * S + S / 2 + rng.uniform(-4, 4), O + r * S + S / 2 + rng.uniform(-4, 4)
            half, ink, w = rng.uniform(9, 15), float(rng.uniform(0.2, 0.9)), int(rng.integers(1, 4))
            if truth[r, c] == 1:
                for sx in (-1, 1):
                    cv2.line(rect, (int(cx - half), int(cy - sx * half)), (int(cx + half), int(cy + sx * half)), ink, w)
            elif truth[r, c] == 2:
                cv2.ellipse(rect, (int(cx), int(cy)), (int(half), int(half * rng.uniform(0.7, 1.0))), 0, 0, 360, ink, w)
    rect += rng.uniform(0, 0.05, rect.shape).astype(np.float32)
    return rect, truth, 0.8


def _inputs(rng: np.random.Generator, boards: int) -> tuple[np.ndarray, np.ndarray]:
    xs, ys = [], []
    for _ in range(boards):
        rect, truth, ref = _board(rng)
        feats = board_features(rect, 3, S, O, 0.25 * ref * 0.5, 0.25 * ref * 0.5, 0.0)
        xs.append(cell_inputs(rect, 3, S, O, feats, _probabilities(feats, ref), ref))
        ys.append(truth.reshape(-1))
    return np.concatenate(xs), np.concatenate(ys)


def test_cell_inputs_see_each_cells_ink_relative_to_the_lines() -> None:
    rect, truth, ref = _board(np.random.default_rng(1))
    feats = board_features(rect, 3, S, O, 0.1, 0.1, 0.0)
    x = cell_inputs(rect, 3, S, O, feats, _probabilities(feats, ref), ref)
    assert x.shape == (9, N_INPUTS) and x.dtype == np.float32
    # the window's middle (it reaches a quarter cell into the neighbours)
    q = WIN // 4
    middle = x[:, :WIN * WIN].reshape(9, WIN, WIN)[:, q:-q, q:-q].reshape(9, -1)
    marked = truth.reshape(-1) > 0
    assert (middle[marked].max(axis=1) > middle[~marked].max(axis=1).max()).all()
    assert np.isclose(x[0, -1], ref) and (x[:, :WIN * WIN] <= 2.0).all()
    # twice the ink with twice as dark lines reads the same
    x2 = cell_inputs(2 * rect, 3, S, O, board_features(2 * rect, 3, S, O, 0.2, 0.2, 0.0),
                     _probabilities(feats, ref), 2 * ref)
    np.testing.assert_allclose(x2[:, :WIN * WIN], x[:, :WIN * WIN], atol=1e-5)
    # the views: as it is, its square root, over the window's darkest (a pale X is an X)
    views = channels(x)
    assert views.shape == (9, N_CHANNELS, WIN, WIN)
    np.testing.assert_allclose(views[:, 1], np.sqrt(views[:, 0]), rtol=1e-6)
    np.testing.assert_allclose(channels(0.3 * x)[marked, 2], views[marked, 2], atol=1e-5)


def _torch_logits(model: CellModel, x: np.ndarray) -> np.ndarray:
    """The reference: the same weights in torch's own layers."""
    import torch
    from torch import nn

    convs = [nn.Conv2d(k.shape[1], k.shape[0], 3, padding=1) for k in (model.k1, model.k2, model.k3)]
    lin1, lin2 = nn.Linear(*model.w4.shape), nn.Linear(*model.w5.shape)
    with torch.no_grad():
        for conv, k, b in zip(convs, (model.k1, model.k2, model.k3), (model.b1, model.b2, model.b3)):
            conv.weight.copy_(torch.from_numpy(k))
            conv.bias.copy_(torch.from_numpy(b))
        for lin, w, b in ((lin1, model.w4, model.b4), (lin2, model.w5, model.b5)):
            lin.weight.copy_(torch.from_numpy(w.T.copy()))
            lin.bias.copy_(torch.from_numpy(b))
        views = (channels(x) - model.cmean[:, None, None]) / model.cscale[:, None, None]
        a = torch.from_numpy(views.astype(np.float32))
        for conv in convs:
            a = nn.functional.max_pool2d(torch.relu(conv(a)), 2)
        v = torch.from_numpy((x[:, WIN * WIN:] - model.smean) / model.sscale)
        return lin2(torch.relu(lin1(torch.cat([a.flatten(1), v], dim=1)))).numpy()


def test_the_numpy_network_computes_what_torchs_layers_compute() -> None:
    """Reading runs the network in numpy (im2col convolutions, channels last); torch's own
    convolution, pooling and linear layers with the same weights are the reference."""
    x, y = _inputs(np.random.default_rng(2), 3)
    model = fit(x, y, hidden=12, epochs=1, convs=(4, 6, 8), progress=False)
    np.testing.assert_allclose(model.logits(x), _torch_logits(model, x), rtol=1e-4, atol=1e-4)


def test_fit_learns_x_from_o_and_is_reproducible() -> None:
    rng = np.random.default_rng(3)
    x, y = _inputs(rng, 60)
    xt, yt = _inputs(rng, 20)
    model = fit(x, y, hidden=16, epochs=8, convs=(4, 8, 8), progress=False)
    assert (model.probs(xt).argmax(axis=1) == yt).mean() >= 0.95
    again = fit(x, y, hidden=16, epochs=8, convs=(4, 8, 8), progress=False)
    np.testing.assert_array_equal(model.k1, again.k1)
    np.testing.assert_array_equal(model.w5, again.w5)
    model.rule_weight = 0.3
    model.temperature = fit_temperature(model, xt, yt)
    assert 0.25 <= model.temperature <= 8.0
    assert expected_calibration_error(model.probs(xt), yt) < 0.1
    # the search runs the network once; the reference asks probs() at every temperature
    ts = np.exp(np.linspace(np.log(0.25), np.log(8.0), 97))
    nll = []
    for t in ts:
        model.temperature = float(t)
        nll.append(-np.mean(np.log(np.maximum(model.probs(xt)[np.arange(len(yt)), yt], 1e-12))))
    assert fit_temperature(model, xt, yt) == float(ts[int(np.argmin(nll))])


def test_collected_cells_are_kept_and_reused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--cells``: the first call collects and writes, the second with the same photos reads the
    file back (no photo rendered), other counts and a cache of the other kind (first grids
    against every right grid, or from before ``all_grids`` was kept) collect anew, and a file
    that is not a cache is named. With ``all_grids`` a photo gives the cells of each of its
    hypotheses whose grid is right (whole boards, the same truth); without, of its first grid."""
    cache = tmp_path / "cells.npz"
    first = load_or_collect(cache, 4, 1, workers=1, progress=False, all_grids=True)
    assert cache.exists() and first.photos == 5
    single = collect(4, 1, workers=1, progress=False)
    views = {}
    for k in np.unique(first.photo):
        y = first.y[first.photo == k]
        n = 9 if len(y) % 25 else 25
        assert len(y) % n == 0 and (y.reshape(-1, n) == y[:n]).all()
        views[int(k)] = len(y) // n
        assert (single.photo == k).sum() in (0, n)  # one view at most: the first grid found's
    assert max(views.values()) >= 2, views  # some photo's grid is found right by more than one hypothesis
    import kinegym.agents.train_cells as tc

    def no_render(*args: object, **kwargs: object) -> None:
        raise AssertionError("collected again although the cache holds these photos")

    monkeypatch.setattr(tc, "collect", no_render)
    again = load_or_collect(cache, 4, 1, workers=1, progress=False, all_grids=True)
    np.testing.assert_array_equal(again.x, first.x)
    np.testing.assert_array_equal(again.photo, first.photo)
    for kwargs in ({"real_like": 5, "all_grids": True}, {"real_like": 4, "all_grids": False}):
        with pytest.raises(AssertionError, match="collected again"):
            load_or_collect(cache, hard=1, workers=1, progress=False, **kwargs)  # type: ignore[arg-type]
    with np.load(cache) as z:  # the same photos' cells as an older trainer kept them (first grids)
        old = {key: z[key] for key in z.files if key != "all_grids"}
    np.savez(tmp_path / "old.npz", **old)
    with pytest.raises(AssertionError, match="collected again"):
        load_or_collect(tmp_path / "old.npz", 4, 1, workers=1, progress=False, all_grids=True)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(FileError, match="bad.npz"):
        load_or_collect(tmp_path / "bad.npz", 4, 1, workers=1, progress=False)


def test_a_model_file_round_trips_and_bad_files_are_named(tmp_path: Path) -> None:
    x, y = _inputs(np.random.default_rng(4), 10)
    model = fit(x, y, hidden=8, epochs=1, convs=(4, 4, 4), progress=False)
    model.temperature, model.info = 1.7, '{"note": "test"}'
    path = tmp_path / "m.npz"
    path.write_bytes(model.to_bytes())
    back = CellModel.load(path)
    np.testing.assert_array_equal(back.probs(x), model.probs(x))
    assert back.describe() == {"note": "test"} and back.temperature == 1.7
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(VisionError, match="junk.npz"):
        CellModel.load(tmp_path / "junk.npz")
    arrays = {key: getattr(model, key) for key in ("cmean", "cscale", "smean", "sscale", "k1", "b1", "k2", "b2", "k3",
                                                   "b3", "w4", "b4", "w5", "b5")}
    np.savez(tmp_path / "shapes.npz", **{**arrays, "w4": arrays["w4"][1:]}, temperature=1.0, rule_weight=0.3, info="{}")
    with pytest.raises(VisionError, match="shapes.npz: cell model with w4"):
        CellModel.load(tmp_path / "shapes.npz")
    np.savez(tmp_path / "part.npz", k1=model.k1)
    with pytest.raises(VisionError, match="lacks cmean"):
        CellModel.load(tmp_path / "part.npz")
    with pytest.raises(VisionError, match="cell_px=30"):
        BoardReader(cell_px=30)
    assert BoardReader(cell_px=30, model=None).model is None


def test_the_training_entry_point_writes_a_model_the_reader_uses(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cells.npz"
    assert main(["--real-like", "10", "--hard", "4", "--workers", "1", "--epochs", "2", "--hidden", "8",
                 "--convs", "4,4,8", "--out", str(out)]) == 0
    report = CellModel.load(out).describe()
    assert report["photos"] == 14 and report["cells_train"] > 0 and "held_out_accuracy" in report
    assert report["convs"] == [4, 4, 8] and CellModel.load(out).k3.shape == (8, 4, 3, 3)
    assert "wrote" in capsys.readouterr().out
    sc = real_like_scene(1_000_000)
    assert BoardReader(size=3, model=str(out)).read(sc.image).cells.shape == (3, 3)
    with pytest.raises(SystemExit):
        main(["--hard", "-1"])
    with pytest.raises(SystemExit):
        main(["--convs", "4,4"])
    assert "--convs 4,4; expected three channel counts" in capsys.readouterr().err


def test_recalibrating_keeps_the_network_and_fits_the_temperature_at_the_new_prior(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = np.random.default_rng(5)
    x, y = _inputs(rng, 40)
    xt, yt = _inputs(rng, 20)
    model = fit(x, y, hidden=8, epochs=2, convs=(4, 4, 8), progress=False)
    model.rule_weight, model.temperature, model.info = 0.3, 1.0, '{"epochs": 2}'
    logits = model.logits(xt)
    record = recalibrate(model, CellData(xt, yt, np.arange(len(yt)) // 9, 20, 20), 0.15)
    np.testing.assert_array_equal(model.logits(xt), logits)  # the network is untouched
    assert model.rule_weight == 0.15 and record["rule_weight_before"] == 0.3
    t = model.temperature
    assert fit_temperature(model, xt, yt) == t and record["temperature"] == round(t, 4)
    info = model.describe()
    assert info["epochs"] == 2 and info["rule_weight"] == 0.15 and info["recalibrated"]["cells"] == len(yt)
    assert "seeds" not in record  # not said where the cells came from
    with pytest.raises(ValueError, match="rule weight -1; expected 0..10"):
        recalibrate(model, CellData(xt, yt, np.zeros(len(yt), np.int64), 1, 1), -1)
    with pytest.raises(ValueError, match="9 cells from 1 photos; expected at least 50"):
        recalibrate(model, CellData(xt[:9], yt[:9], np.zeros(9, np.int64), 1, 1), 0.1)
    # through the entry point, on photos from the recalibration seeds: a copy written, the source kept
    src, out = tmp_path / "m.npz", tmp_path / "recal.npz"
    src.write_bytes(model.to_bytes())
    assert main(["--recalibrate", str(src), "--rule-weight", "0.05", "--real-like", "8", "--hard", "1",
                 "--workers", "1", "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    again = CellModel.load(out)
    assert again.rule_weight == 0.05 and CellModel.load(src).rule_weight == 0.15
    np.testing.assert_array_equal(again.k1, model.k1)
    assert again.describe()["recalibrated"]["seeds"] == [5_000_000, 6_000_000]


def test_the_shipped_model_beats_the_rule_on_unseen_real_like_photos() -> None:
    """40 real-like photos from seeds neither trained on (1,000,000 on) nor benchmarked (20,000 on):
    the shipped model reads more cells right than the hand rule, and its confidences are
    calibrated (ECE at most 0.06 over the cells of the boards whose grid was found right: on a
    wrong grid no cell's call means anything)."""
    learned, rule = BoardReader(size=3), BoardReader(size=3, model=None)
    hits_model = hits_rule = 0
    probs, truth = [], []
    for seed in range(30_000, 30_040):
        sc = real_like_scene(seed)
        try:
            a, b = learned.read(sc.image), rule.read(sc.image)
        except NoBoardError:
            continue
        hits_model += int((a.cells == sc.cells).sum())
        hits_rule += int((b.cells == sc.cells).sum())
        if grid_is_right(a.homography, sc.centres_px.reshape(-1, 2), 3):
            probs.append(a.probs.reshape(-1, 3))
            truth.append(sc.cells.reshape(-1))
    assert hits_model > hits_rule, (hits_model, hits_rule)
    assert expected_calibration_error(np.concatenate(probs), np.concatenate(truth)) <= 0.06


def test_the_shipped_ensemble_averages_its_members(tmp_path: Path) -> None:
    """The reader's default model is the ensemble of :data:`SHIPPED_MODELS` (the first-grid and the
    every-right-grid model, the second trained with ``--all-grids``); its probabilities are the
    mean of its members', a list of paths makes one, and a bad member is named."""
    reader = BoardReader()
    assert isinstance(reader.model, CellEnsemble) and len(reader.model.members) == 2
    first, every = (CellModel.load(p) for p in SHIPPED_MODELS)
    assert every.describe()["all_grids"] is True and not first.describe().get("all_grids", False)
    trace: dict[str, object] = {}
    reader.read(real_like_scene(20_000).image, trace)
    x = np.asarray(trace["cell_inputs"])
    got = reader.model.probs(x)
    np.testing.assert_allclose(got, 0.5 * (first.probs(x) + every.probs(x)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.sum(axis=1), 1.0, atol=1e-9)
    assert not np.allclose(first.probs(x), every.probs(x))  # two models, not one twice
    assert isinstance(BoardReader(model=[str(p) for p in SHIPPED_MODELS]).model, CellEnsemble)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(VisionError, match="bad.npz"):
        BoardReader(model=[str(SHIPPED_MODELS[0]), str(tmp_path / "bad.npz")])
    with pytest.raises(VisionError, match="no models"):
        CellEnsemble(())
