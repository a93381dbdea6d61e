"""The command line: the demo, the kinematics commands, exit codes 0 / 2 / 3, --json."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from kinegym.cli import main


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_demo_writes_picture_and_summary(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # --quick: the game with ideal strokes (CI runs the full demo once, as the README's first command)
    code, out, _ = run(capsys, "demo", "--out", str(tmp_path), "--json", "--quick")
    assert code == 0
    summary = json.loads(out)
    assert all(step["status"] in ("ok", "reproduced") for step in summary["steps"])
    steps = [s["step"] for s in summary["steps"]]
    assert "HoleClimb-v0: planner climbs" in steps and "TicTacToeDraw-v0: arm vs thesis player" in steps
    png = Path(summary["files"][0])
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000
    names = {Path(f).name for f in summary["files"]}
    assert {"climb.gif", "game.gif", "game_photo.png"} <= names
    assert all(Path(f).stat().st_size > 1000 for f in summary["files"])


def test_ik_climber_json_reproduces_seed(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    plot = tmp_path / "robot.png"
    code, out, _ = run(capsys, "ik", "climber", "--holes", "20,0;0,20;0,0", "--center", "6.6289,7.7378",
                       "--json", "--plot", str(plot))
    assert code == 0
    angles = json.loads(out)["angles_deg"]
    assert angles[0][0] == pytest.approx(-69.4851, abs=1e-3)
    assert angles[2][1] == pytest.approx(61.2544, abs=1e-3)
    assert plot.exists()


def test_fk_climber_negative_angles_and_distances(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "fk", "climber", "--angles", "-24,85;78,55;-155,103", "--json")
    assert code == 0
    d = json.loads(out)["hand_distances_cm"]
    assert d == pytest.approx([19.5231, 19.8823, 27.4149], abs=1e-4)


def test_ik_arm_text_and_fk_roundtrip(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "ik", "arm", "--target", "15,0,7", "--json")
    assert code == 0
    q = json.loads(out)["q_deg"]
    code, out, _ = run(capsys, "fk", "arm", "--q", ",".join(map(str, q)), "--json")
    res = json.loads(out)
    assert [res["x_cm"], res["y_cm"], res["z_cm"], res["phi_deg"]] == pytest.approx([15, 0, 7, -90], abs=1e-4)


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["ik", "arm", "--target", "1,2"], "--target '1,2'"),
        (["ik", "climber", "--holes", "1,2;3,4", "--center", "0,0"], "--holes '1,2;3,4'"),
        (["ik", "climber", "--holes", "1,2;3,4;5,x", "--center", "0,0"], "'5,x'"),
        (["ik", "arm", "--target", "15,0,7", "--arm", "nosuch"], "'nosuch'"),
        (["ik", "climber", "--holes", "1,0;0,1;1,1", "--center", "0,0", "--link", "-3"], "--link -3"),
        (["frobnicate"], "frobnicate"),
    ],
)
def test_bad_input_exit_2_one_line(capsys: pytest.CaptureFixture[str], argv: list[str], needle: str) -> None:
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert needle in err and len(err.strip().splitlines()) == 1


def test_unanswerable_exit_3_with_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "ik", "arm", "--target", "60,0,5", "--json")
    assert code == 3
    assert json.loads(out)["error"] == "UnreachableError"
    code, out, _ = run(capsys, "ik", "climber", "--holes", "50,0;0,5;-5,0", "--center", "0,0", "--json")
    assert code == 3 and json.loads(out)["arm"] == 1


def test_console_script_help_and_no_traceback() -> None:
    exe = Path(sys.executable).with_name("kinegym")
    for argv in (["--help"], ["ik", "arm", "--help"], ["demo", "--help"]):
        done = subprocess.run([str(exe), *argv], capture_output=True, text=True, check=False)
        assert done.returncode == 0 and "usage" in done.stdout
    bad = subprocess.run([str(exe), "ik", "arm", "--target", "a,b,c"], capture_output=True, text=True)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    # a reader that goes away (`kinegym ... | head`) ends the command quietly
    for argv in (["--help"], ["solve", "X...|.O..|....|....", "--k", "3"]):
        proc = subprocess.Popen([str(exe), *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        proc.stdout.close()  # type: ignore[union-attr]
        err = proc.stderr.read()  # type: ignore[union-attr]
        proc.wait(timeout=60)
        assert "Traceback" not in err and "Exception ignored" not in err, err


def test_import_kinegym_is_light() -> None:
    code = ("import sys, kinegym, kinegym.cli; "
            "print(sorted(m for m in ('pymunk', 'pygame', 'cv2', 'torch') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


def test_localize_seed_example(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    angles = "-24,85;78,55;-155,103"
    code, out, _ = run(capsys, "localize", "--angles", angles, "--tolerance", "0.15", "--json")
    assert code == 0
    assert json.loads(out)["ids"] == [[4, 3], [3, 3], [3, 2]]
    plot = tmp_path / "amb.png"
    code, out, _ = run(capsys, "localize", "--angles", angles, "--sigma", "0.5", "--json", "--plot", str(plot))
    assert code == 3
    res = json.loads(out)
    assert res["error"] == "AmbiguousFixError" and res["candidates"][0]["ids"] == [[4, 3], [3, 3], [3, 2]]
    assert plot.exists()
    code, _, err = run(capsys, "localize", "--angles", angles, "--sigma", "-1")
    assert code == 2 and "--sigma" in err
    code, _, err = run(capsys, "localize", "--angles", angles, "--wall", "grid:ax3")
    assert code == 2 and "grid:ax3" in err


def test_sensor_study_cli(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, out, _ = run(capsys, "sensor-study", "--sigmas", "0.2,1", "--trials", "60", "--walks", "5",
                       "--out", str(tmp_path), "--json")
    assert code == 0
    res = json.loads(out)
    assert [round(r["sigma_deg"], 6) for r in res["rows"]] == [0.2, 1.0]
    assert all(r["wrong"] == 0 for r in res["rows"])
    assert (tmp_path / "sensor_study.png").stat().st_size > 5000


def test_solve_prints_value_and_best_moves(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "solve", "XX.|OO.|...", "--json")
    assert code == 0
    res = json.loads(out)
    assert res["value"] == 1 and res["best_moves"] == [[0, 2]] and res["to_move"] == "X"
    code, out, _ = run(capsys, "solve", ".....|.....|..X..|.....|.....")
    assert code == 0 and "draw for O" in out and "(1, 1)" in out


def test_solve_bad_and_finished_boards(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "solve", "XX.|O.")
    assert code == 2 and "rows of lengths" in err
    code, out, _ = run(capsys, "solve", "XXX|OO.|...", "--json")
    assert code == 3 and json.loads(out)["result"] == "X wins"


def test_match_tallies(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "match", "--x", "random", "--o", "solver", "--games", "4", "--board", "3", "--json")
    res = json.loads(out)
    assert code == 0 and res["games"] == 4 and res["x_wins"] == 0
    code, _, err = run(capsys, "match", "--x", "nobody")
    assert code == 2 and "'nobody'" in err


def test_read_board_reads_a_photo_and_refuses_a_blank(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import cv2
    import numpy as np

    from kinegym.envs.sim.scenes import random_scene

    sc = random_scene(5, difficulty="hard")
    img = tmp_path / "board.jpg"
    cv2.imwrite(str(img), sc.photo.image[..., ::-1])
    dbg = tmp_path / "debug.png"
    code, out, _ = run(capsys, "read-board", str(img), "--size", "5", "--json", "--debug", str(dbg))
    assert code == 0 and json.loads(out)["cells"] == sc.cells.tolist() and dbg.stat().st_size > 1000
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((240, 320, 3), 230, np.uint8))
    code, out, _ = run(capsys, "read-board", str(blank), "--json")
    assert code == 3 and json.loads(out)["error"] == "NoBoardError"
    code, _, err = run(capsys, "read-board", str(tmp_path / "missing.png"))
    assert code == 2 and "no such file" in err
