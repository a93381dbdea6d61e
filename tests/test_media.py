"""Pictures people look at: matplotlib charts, round ticks on the live panels, .mp4 beside .gif,
and gymnasium's RecordVideo on our envs (the ``video`` extra)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from kinegym.configs.io import FileError
from kinegym.envs.charts import line_chart
from kinegym.envs.draw import live_chart, nice_ticks, save_gif


def test_nice_ticks_are_round() -> None:
    assert nice_ticks(0.0, 1.02, 5) == [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    assert nice_ticks(0.0, 1813.4, 4) == [0.0, 500.0, 1000.0, 1500.0]
    assert nice_ticks(-3.3, 2.1, 5) == [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0]


def test_charts_are_rgb_arrays_of_the_asked_size() -> None:
    x = np.linspace(0, 2, 50)
    img = line_chart({"a": (x, np.sin(x)), "b": (x, np.cos(x))}, "t", "time (s)", "value (cm)", size=(640, 360))
    assert img.shape == (360, 640, 3) and img.dtype == np.uint8 and img.std() > 10
    # a series of one point (a run with a single validation) still shows, markers or not: against
    # the same chart with that point missing (same legend), its marker adds orange (C1) pixels
    long = (np.linspace(0, 1, 100), np.full(100, 0.5))

    def orange(point: float) -> int:
        img = line_chart({"train": long, "validation": ([0.5], [point])}, "t", "steps", "success",
                         ylim=(0, 1.02), markers=False).astype(int)
        return int(((img[..., 0] - img[..., 2] > 120) & (img[..., 1] > 80)).sum())

    assert orange(0.9) > orange(float("nan")) + 10
    live = live_chart({"a": (x, np.sin(x)), "b": (x, np.cos(x))}, "pen x", "t (s)", "cm")
    assert live.shape == (160, 345, 3)


def test_mp4_beside_gif(tmp_path: Path) -> None:
    pytest.importorskip("imageio_ffmpeg")
    import imageio_ffmpeg

    frames = [np.full((61, 81, 3), 20 * i, np.uint8) for i in range(8)]  # odd sides: padded to even
    out = save_gif(frames, tmp_path / "a.mp4", fps=4)
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    assert meta["size"] == (82, 62) and sum(1 for _ in reader) == 8
    assert save_gif(frames, tmp_path / "a.gif", fps=4).stat().st_size > 0
    with pytest.raises(FileError, match=r"\.gif or \.mp4"):
        save_gif(frames, tmp_path / "a.avi", fps=4)


def test_record_video_works_on_our_envs(tmp_path: Path) -> None:
    pytest.importorskip("moviepy")
    env = gym.wrappers.RecordVideo(gym.make("kinegym/HoleClimb-v0", render_mode="rgb_array"), str(tmp_path),
                                   episode_trigger=lambda i: i == 0, disable_logger=True)
    _, info = env.reset(seed=1)
    for _ in range(5):
        _, _, term, trunc, info = env.step(int(np.flatnonzero(info["action_mask"])[0]))
        if term or trunc:
            break
    env.close()
    assert list(tmp_path.glob("*.mp4"))
