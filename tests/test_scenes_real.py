"""The real-like renderer (envs.sim.scenes_real) and the board reader on its photos: the
same seed gives the same photo, the truth matches what was drawn, the conditions it
promises occur, and the reader holds a measured floor on them without ever crashing."""

import numpy as np

from kinegym.envs.sim.scenes_real import real_like_scene
from kinegym.vision.board_reader import BoardReader, NoBoardError


def test_same_seed_same_photo_and_truth() -> None:
    a, b = real_like_scene(7, width=640), real_like_scene(7, width=640)
    assert np.array_equal(a.image, b.image) and a.text() == b.text()
    assert not np.array_equal(a.image, real_like_scene(8, width=640).image)


def test_every_cell_centre_lies_in_the_photo_and_marks_leave_ink_there() -> None:
    """The truth's cell centres are inside the frame (even when the grid is cut off), and a
    marked cell is darker around its centre than an empty one on average."""
    marked, empty = [], []
    for seed in range(30):
        sc = real_like_scene(seed, width=640)
        h, w = sc.image.shape[:2]
        assert np.all((sc.centres_px > 0) & (sc.centres_px < [w, h])), seed
        grey = sc.image.mean(axis=2)
        step = np.linalg.norm(sc.centres_px[1, 1] - sc.centres_px[1, 0])
        r = max(2, int(0.3 * step))
        for (row, col), v in np.ndenumerate(sc.cells):
            x, y = np.rint(sc.centres_px[row, col]).astype(int)
            patch = grey[max(0, y - r):y + r, max(0, x - r):x + r]
            (marked if v else empty).append(float(np.percentile(patch, 98) - patch.min()))
    assert np.mean(marked) > 1.5 * np.mean(empty)


def test_the_promised_conditions_occur() -> None:
    seen: dict[str, int] = {}
    sizes = set()
    for seed in range(120):
        notes = real_like_scene(np.random.default_rng(seed), width=520).notes
        sizes.add((notes["width"], notes["height"]))
        for key in ("ghosts", "second_grid", "binding", "pen_in_view", "highlighter", "cut_off", "hard_shadow",
                    "light_spot", "reflection", "gone_over"):
            seen[key] = seen.get(key, 0) + bool(notes.get(key))
        seen[notes["surface"]] = seen.get(notes["surface"], 0) + 1
    assert all(seen.get(k, 0) >= 3 for k in ("ghosts", "second_grid", "binding", "pen_in_view", "highlighter",
                                             "cut_off", "hard_shadow", "light_spot", "reflection", "gone_over", "graph",
                                             "notebook", "whiteboard", "paper")), seen
    assert {(520, 390), (520, 693)} <= sizes  # landscape and portrait


def test_large_photos_are_rendered_at_their_size() -> None:
    sc = real_like_scene(3, width=4000)
    assert sc.image.shape[1] == 4000 and sc.image.shape[0] in (3000, 5333)


def test_the_reader_never_crashes_and_holds_its_floor() -> None:
    """30 real-like photos at their drawn sizes (seeds 10,040 on; seed 10,054 once raised an
    IndexError in the '#' tracer): only NoBoardError may come out, and at least 70 % of the
    cells read right (measured on 240 photos, seeds 20,000 on: 79 %; see bench/README)."""
    right = total = 0
    for seed in range(10_040, 10_070):
        sc = real_like_scene(seed)
        try:
            text = BoardReader().read(sc.image).text()
        except NoBoardError:
            text = ""
        truth = sc.text()
        right += sum(a == b for a, b in zip(text, truth) if b != "|") if len(text) == len(truth) else 0
        total += 9
    assert right >= 0.7 * total, right / total
