"""Hostile input, measured: the CLI's argument grammar and the YAML schemas fuzzed with
hypothesis, hostile files and output paths, in-process and through the console script.

Every case must end as exit 0, 2 or 3 with no traceback, within a time bound; the YAML
loaders must answer with :class:`~kinegym.configs.ConfigError` (or load) and never hang.
The cases run are counted in each test's docstring; ``tests/test_fuzz.py -v`` lists them.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kinegym.cli import main
from kinegym.configs import ConfigError, FileError, load_yaml, parse_yaml, write_atomic

BOMB = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [{', '.join(['*' + p] * 10)}]\n" for p, c in zip("abcdefgh", "bcdefghi")) + "top: *i\n"

#: hostile values for any option (numbers, text, sizes)
HOSTILE = ["-1", "0", "1e308", "-1e308", "nan", "inf", "-inf", "", " ", "1,2", "1,,2", "abc", "\u00e9\u4e2d",
           "999999999999", "-0", "1e-320", "3;4;5", "0x10", "1_000", "--", "'", "%s%s", "../../etc/passwd"]
#: cheap commands whose options the grammar fuzz draws from
CHEAP = ["ik climber", "ik arm", "fk climber", "fk arm", "localize", "solve", "follow", "precision", "calibrate",
         "match", "sensor-study"]
FAST_DEFAULTS = {"solve": ["--time-limit", "2"], "match": ["--games", "2"],
                 "sensor-study": ["--trials", "20", "--walks", "2"], "follow": ["--max-steps", "50"]}


def _options(command: str) -> list[str]:
    import argparse

    from kinegym.cli import build_parser

    sp: argparse.ArgumentParser = build_parser()
    for word in command.split():
        sub = next(a for a in sp._actions if isinstance(a, argparse._SubParsersAction))
        sp = sub.choices[word]
    return [a.option_strings[-1] for a in sp._actions if a.option_strings and a.dest not in ("help", "json")]


def _run(argv: list[str], limit_s: float = 30.0) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    took = time.perf_counter() - t0
    assert took < limit_s, f"{argv} took {took:.1f} s"
    return code, out.getvalue() + err.getvalue()


@pytest.fixture(scope="module", autouse=True)
def scratch_cwd(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    """Every case runs in a scratch folder: a fuzzed relative ``--out`` (``calibrate --out
    <random text>`` is a valid file name) must land there, never in the user's checkout."""
    here = os.getcwd()
    os.chdir(tmp_path_factory.mktemp("cwd"))
    yield
    os.chdir(here)


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("hostile")
    f = {"bomb": d / "bomb.yaml", "binary": d / "binary.yaml", "empty": d / "empty.yaml", "list": d / "list.yaml",
         "png_binary": d / "noise.png", "dir": d / "adir", "file": d / "plain.txt"}
    f["bomb"].write_text(BOMB)
    f["binary"].write_bytes(bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8)))
    f["empty"].write_text("")
    f["list"].write_text("- 1\n- 2\n")
    f["png_binary"].write_bytes(b"\x89PNG\r\n\x1a\n" + os.urandom(200))
    f["dir"].mkdir()
    f["file"].write_text("not a folder\n")
    return f


def test_the_yaml_loader_refuses_bombs_binary_and_oversize(tmp_path: Path) -> None:
    """A billion-laughs file is refused in well under a second; binary, oversize, missing
    files and folders are FileErrors naming the path."""
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(BOMB)
    t0 = time.perf_counter()
    with pytest.raises(FileError, match="expanding to more than"):
        load_yaml(bomb)
    assert time.perf_counter() - t0 < 1.0
    (tmp_path / "bin.yaml").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(FileError, match="not UTF-8"):
        load_yaml(tmp_path / "bin.yaml")
    (tmp_path / "big.yaml").write_text("a: " + "x" * (1 << 20) + "\n")
    with pytest.raises(FileError, match="bytes"):
        load_yaml(tmp_path / "big.yaml")
    with pytest.raises(FileError, match="no such file"):
        load_yaml(tmp_path / "missing.yaml")
    with pytest.raises(FileError, match="folder"):
        load_yaml(tmp_path)
    with pytest.raises(FileError, match="unparsable"):
        parse_yaml("a: [1, 2\n", "x.yaml")
    assert parse_yaml("a: &x [1, 2]\nb: *x\n") == {"a": [1, 2], "b": [1, 2]}  # a few aliases are fine


def test_the_writer_is_atomic_and_names_bad_paths(tmp_path: Path) -> None:
    out = write_atomic(tmp_path / "new" / "deep" / "a.txt", "hello")
    assert out.read_text() == "hello" and not [p for p in out.parent.iterdir() if p.name.startswith(".")]
    umask = os.umask(0o022)
    try:  # the mode a plain open() gives, not mkstemp's private 0600
        assert write_atomic(tmp_path / "b.txt", "x").stat().st_mode & 0o777 == 0o644
    finally:
        os.umask(umask)
    (tmp_path / "plain").write_text("x")
    for bad, needle in ((tmp_path / "plain" / "a.txt", "is a file"), (tmp_path / "new", "a folder"),
                        (tmp_path / "x.bmp", "extension")):
        with pytest.raises(FileError, match=needle):
            write_atomic(bad, "x", suffixes=(".txt",) if bad.suffix == ".bmp" else None)
    if os.geteuid() != 0:  # root writes anywhere
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o555)
        with pytest.raises(FileError, match="cannot be written"):
            write_atomic(ro / "a.txt", "x")


yaml_values = st.recursive(
    st.none() | st.booleans() | st.integers(-10**30, 10**30) | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=12),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4), max_leaves=12)


@pytest.mark.parametrize("kind", ["robots", "arms", "walls", "beacons", "train", "arm_errors", "measurements"])
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_every_schema_answers_fuzzed_yaml_with_a_config_error(kind: str, data: st.DataObject, tmp_path: Path) -> None:
    """40 documents per schema (7 schemas: 280), each a built-in file with random keys mutated:
    loads, or a ConfigError that names the file; nothing else escapes."""
    from kinegym.configs import CONFIG_DIR, available

    name = available(kind)[0]
    base = yaml.safe_load((CONFIG_DIR / kind / f"{name}.yaml").read_text())
    doc = base
    if kind == "train":
        doc = dict(base)
        (env_id,) = doc
        section = dict(doc[env_id])
        key = data.draw(st.sampled_from(sorted(section) + ["env_kwargs.wall_kwargs", "policy_kwargs.net_arch",
                                                            "unknown"]))
        section[key.split(".")[0]] = data.draw(yaml_values)
        doc[env_id] = section
    elif isinstance(base, dict):
        doc = dict(base)
        key = data.draw(st.sampled_from(sorted(doc) + ["unknown"]))
        doc[key] = data.draw(yaml_values)
    path = tmp_path / f"fuzz_{kind}.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    loaders = {
        "robots": lambda p: __import__("kinegym.envs.sim.climber_model", fromlist=["x"]).ClimberModel.from_config(p),
        "arms": lambda p: __import__("kinegym.kinematics.writing_arm", fromlist=["x"]).WritingArm.from_config(p),
        "walls": lambda p: __import__("kinegym.kinematics.holes", fromlist=["x"]).HoleMap.from_config(p),
        "beacons": lambda p: __import__("kinegym.kinematics.mobile", fromlist=["x"]).load_scene(p),
        "train": lambda p: __import__("kinegym.agents.train", fromlist=["x"]).load_train_config(p),
        "arm_errors": lambda p: __import__("kinegym.kinematics.arm_errors", fromlist=["x"]).ArmErrors.from_config(p),
        "measurements": lambda p: __import__("kinegym.kinematics.arm_errors", fromlist=["x"]).load_measurements(p),
    }
    try:
        loaders[kind](str(path))
    except ConfigError as err:
        assert str(path) in str(err)
    except ValueError as err:  # a named input error of the consumer (InvalidInputError, ...)
        assert type(err).__name__ != "ValueError" or "expected" in str(err), repr(err)


@settings(max_examples=200, deadline=None)
@given(command=st.sampled_from(CHEAP), data=st.data())
def test_the_cli_grammar_fuzzed_ends_cleanly(command: str, data: st.DataObject) -> None:
    """200 command lines: a cheap command, 1-3 of its options with hostile values: exit 0, 2 or
    3 (a one-line message on 2), no exception escapes, each within 30 s."""
    opts = _options(command)
    argv = command.split() + (["X..|.O.|..."] if command == "solve" else [])
    for opt in data.draw(st.lists(st.sampled_from(opts), min_size=1, max_size=3, unique=True)):
        argv += [opt, data.draw(st.sampled_from(HOSTILE) | st.text(max_size=10))]
    argv += FAST_DEFAULTS.get(command, [])
    code, text = _run(argv)
    assert code in (0, 2, 3), (argv, code, text[-500:])
    assert "Traceback" not in text


OUTPUT_CASES = [
    ("follow", "--out"), ("follow", "--gif"), ("localize", "--plot"), ("calibrate", "--out"),
    ("sensor-study", "--out"), ("precision", "--out"),
]


@pytest.mark.parametrize(("command", "option"), OUTPUT_CASES)
@pytest.mark.parametrize("where", ["under_file", "no_extension", "is_dir", "proc"])
def test_output_paths_are_named_errors(command: str, option: str, where: str, files: dict[str, Path]) -> None:
    """6 output options x 4 bad places = 24 cases: a folder under a file, a path without an
    image extension, an existing folder, a place that cannot be made: exit 2, no traceback."""
    target = {"under_file": files["file"] / "x" / "out.png", "no_extension": files["dir"] / "picture",
              "is_dir": files["dir"], "proc": Path("/proc/kinegym-fuzz/out.png")}[where]
    if option == "--out" and command != "calibrate" and where in ("no_extension", "is_dir"):
        target = files["file"] / "sub"  # a folder option given a path under a file
    argv = command.split() + [option, str(target)]
    if command == "localize":
        argv += ["--angles", "-24,85;78,55;-155,103", "--tolerance", "0.15"]
    if command == "sensor-study":
        argv += ["--trials", "20", "--walks", "2", "--sigmas", "0.5"]
    if command == "follow":
        argv += ["--max-steps", "20"]
    code, text = _run(argv)
    assert code == 2 and "Traceback" not in text, (argv, code, text[-400:])
    assert str(target) in text or target.name in text or "--out" in text


@pytest.mark.parametrize("kind", ["bomb", "binary", "empty", "list", "dir", "missing"])
@pytest.mark.parametrize("argv", [["localize", "--angles", "-24,85;78,55;-155,103", "--wall"],
                                  ["localize", "--angles", "-24,85;78,55;-155,103", "--robot"],
                                  ["ik", "arm", "--target", "12,7,5", "--arm"], ["follow", "--scene"],
                                  ["precision", "--errors"], ["calibrate", "--measured"],
                                  ["train", "gait", "--config"], ["read-board"], ["climb", "--policy"]])
def test_hostile_input_files_are_named_errors(argv: list[str], kind: str, files: dict[str, Path]) -> None:
    """9 file options x 6 hostile files = 54 cases: exit 2 naming the file, within 30 s."""
    if argv[0] == "read-board" and kind == "binary":
        path = files["png_binary"]
    else:
        path = files.get(kind, files["dir"] / "missing.yaml")
    code, text = _run([*argv, str(path)])
    assert code == 2 and "Traceback" not in text, (argv, kind, code, text[-400:])


def test_corrupt_policies_and_seeds_are_named_errors(tmp_path: Path) -> None:
    empty, noise, junk = tmp_path / "empty.zip", tmp_path / "noise.zip", tmp_path / "junk.zip"
    empty.write_bytes(b"")
    noise.write_bytes(os.urandom(2048))
    with zipfile.ZipFile(junk, "w") as zf:
        zf.writestr("data", '{"policy_class": {":serialized:": "gARdLg=="}, "evil": {":serialized:": "gAQu"}}')
        zf.writestr("policy.pth", b"xx")
    for p in (empty, noise, junk):
        code, text = _run(["climb", "--policy", str(p), "--episodes", "1"])
        assert code == 2 and "Traceback" not in text, text
    code, text = _run(["climb", "--policy", str(junk), "--episodes", "1"])
    assert "evil" in text  # a pickled object kinegym does not know is refused, not run
    for argv in (["climb", "--seed", "-1"], ["match", "--seed", str(2**40)], ["draw", "--seed", "-5"]):
        code, text = _run(argv)
        assert code == 2 and "--seed" in text


def test_solve_has_a_time_budget() -> None:
    t0 = time.perf_counter()
    code, text = _run(["solve", "......|......|......|......|......|......", "--time-limit", "1"])
    assert code == 3 and "unknown within the budget" in text and time.perf_counter() - t0 < 10


def test_numbers_that_overflow_are_named(capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["fk", "climber", "--angles", "0,0;0,0;0,0", "--link", "1e308"],
                 ["fk", "climber", "--angles", "0,0;0,0;0,0", "--pose", "1e308,0,0"],
                 ["ik", "climber", "--holes", "1e308,0;0,20;0,0", "--center", "6,7"]):
        code, text = _run(argv)
        assert code == 2 and "Traceback" not in text and "inf" not in text.split("expected")[0], (argv, text)
    assert not math.isnan(0.0)


def test_the_console_script_never_shows_a_traceback(files: dict[str, Path]) -> None:
    """Through the installed ``kinegym`` script (a fresh process, as a user runs it)."""
    for argv in (["localize", "--wall", str(files["bomb"]), "--angles", "-24,85;78,55;-155,103"],
                 ["read-board", str(files["png_binary"])], ["follow", "--gif", str(files["file"] / "a.gif")]):
        r = subprocess.run([sys.executable, "-m", "kinegym", *argv], capture_output=True, text=True, timeout=120)
        assert r.returncode == 2 and "Traceback" not in r.stderr + r.stdout, r.stderr[-500:]


@pytest.mark.parametrize("argv", [
    ["match", "--games", "1000000000000"], ["climb", "--episodes", "99999999999999999999"],
    ["sensor-study", "--trials", "4294967296"], ["sensor-study", "--walks", "1000000000000"],
    ["sensor-study", "--sigmas", ",".join(["0.1"] * 40)], ["evaluate", "gait", "--policy", "x.zip", "--episodes", "0"],
    ["localize", "--angles", "-24,85;78,55;-155,103", "--sigma", "1e12"],
    ["localize", "--angles", "-24,85;78,55;-155,103", "--map-sigma", "1e12"],
    ["localize", "--angles", "-24,85;78,55;-155,103", "--wall", "grid:3000x3000"],
    ["train", "gait", "--timesteps", "1000000000000"], ["tune", "gait", "--storage", "x", "--study", "s",
                                                        "--trials", "0"]])
def test_unbounded_work_is_refused_with_the_maximum(argv: list[str]) -> None:
    """11 counts and sizes past their maxima (each once made a run hang): exit 2 at once."""
    code, text = _run(argv, limit_s=10)
    assert code == 2 and ("expected" in text or " in 0.." in text) and "Traceback" not in text, (argv, text)


def test_degenerate_walls_end_cleanly(tmp_path: Path) -> None:
    one, same = tmp_path / "one.yaml", tmp_path / "same.yaml"
    one.write_text("name: one\nholes:\n  - {id: [1, 1], xy_cm: [0.0, 0.0]}\n")
    same.write_text("name: same\nholes:\n" + "".join(f"  - {{id: [{i}, 1], xy_cm: [0.0, 0.0]}}\n" for i in range(5)))
    code, text = _run(["climb", "--episodes", "1", "--wall", str(one)])
    assert code == 3 and "no route" in text
    code, text = _run(["sensor-study", "--trials", "10", "--walks", "1", "--wall", str(same), "--out", str(tmp_path)])
    assert code == 2 and "0.1 cm apart" in text


@pytest.mark.parametrize("argv", [
    ["follow", "--model", "tricycle", "--length", "1e-320", "--max-steps", "5"],
    ["draw", "--shape", "sine", "--size", "1e308"], ["draw", "--shape", "field", "--size", "inf"],
    ["draw", "--shape", "lines", "--size", "1e12"], ["localize", "--angles", "-24,85;78,55;-155,103", "--tolerance",
                                                     "1e308"],
    ["localize", "--angles", "-24,85;78,55;-155,103", "--wall", "grid:99999999999999999999x2"],
    ["sensor-study", "--sigmas", "1e-320"], ["servo", "tune", "--out", "gains.txt"]])
def test_what_the_fuzz_campaign_found_stays_fixed(argv: list[str], tmp_path: Path) -> None:
    """8 command lines a 1,700-case subprocess campaign once broke (tracebacks): exit 2 now."""
    code, text = _run([*argv, *(["--out", str(tmp_path)] if argv[0] == "draw" else [])], limit_s=20)
    assert code == 2 and "Traceback" not in text, (argv, text)


def test_an_image_claiming_gigapixels_is_refused(tmp_path: Path) -> None:
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 100_000, 100_000, 8, 2, 0, 0, 0)) + \
        chunk(b"IEND", b"")
    (tmp_path / "bomb.png").write_bytes(png)
    code, text = _run(["read-board", str(tmp_path / "bomb.png")])
    assert code == 2 and "pixels" in text


def test_training_and_tuning_inputs_fail_before_any_work(tmp_path: Path) -> None:
    """What the campaign found in train/tune: each refused in well under a second of work."""
    (tmp_path / "afile").write_text("x")
    long = "x" * 300
    for argv, needle in ((["tune", "gait", "--storage", "sqlite://", "--study", "s"], "in-memory"),
                         (["tune", "gait", "--storage", f"sqlite:///{tmp_path}/t.db", "--study", "s", "--config",
                           long], "file name"),
                         (["tune", "gait", "--storage", f"sqlite:///{tmp_path}/t.db", "--study", "s", "--config",
                           str(tmp_path / "missing.yaml")], "missing.yaml"),
                         (["train", "gait", "--timesteps", "64", "--out", str(tmp_path / "afile")], "run folder")):
        code, text = _run(argv, limit_s=30)
        assert code == 2 and needle in text and "Traceback" not in text, (argv, text)
    assert not (tmp_path / "t.db").exists() or (tmp_path / "t.db").stat().st_size >= 0
