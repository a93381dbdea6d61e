"""The README a newcomer reads: balanced code fences, links and pictures that exist, a table of
contents that matches its sections, the generated env reference up to date, and every shell
example it shows run for its exit code (bar the long or interactive ones, each named with why)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", ROOT / "bench" / "README.md", ROOT / "kinegym" / "docs" / "environments.md"]

#: shell examples not run here, and why (each runs elsewhere or needs what a test has not)
NOT_RUN = {
    "python -m kinegym.zoo": "RL Zoo trains and plays in tests/test_zoo.py, with fewer steps",
    "python -m kinegym.agents.train_cells": "31 min; tests/test_cell_model.py trains through the same entry point "
                                            "on 14 photos",
    "python -m kinegym.agents.train_grid_arbiter": "25 min; tests/test_grid_choice.py trains through the same entry "
                                                   "point on 13 photos",
    "kinegym sensor-study --wall seed_4x4 --sigmas 0.1,0.25,0.5,1 --trials 2000": "minutes; test_cli runs a small one",
    "kinegym read-board photo.jpg": "the user's own photo; test_cli reads a rendered one",
    "kinegym play": "interactive (a person types moves); tests/test_gui.py drives it",
    "kinegym train gait": "minutes to hours; tests/test_train.py trains small runs",
    "kinegym evaluate gait": "needs a trained run; tests/test_train.py evaluates one",
    "kinegym climb --policy": "needs a trained run; tests/test_train.py",
    "kinegym selfplay": "minutes; tests/test_tictactoe_aec.py runs a short one",
    "kinegym servo tune": "a 12 s search; tests/test_servo.py runs it",
    "kinegym match --x solver --o thesis --games 100": "a minute; test_cli runs a short match",
}


def _fences(text: str) -> list[tuple[int, str, list[str]]]:
    """(line, language, body lines) of every fenced block; AssertionError if one never closes."""
    blocks, open_at, lang, body = [], None, "", []
    for i, line in enumerate(text.splitlines(), 1):
        if line.startswith("```"):
            if open_at is None:
                open_at, lang, body = i, line[3:].strip(), []
            else:
                assert line.strip() == "```", f"line {i}: a fence opens inside the block opened at {open_at}"
                blocks.append((open_at, lang, body))
                open_at = None
        elif open_at is not None:
            body.append(line)
    assert open_at is None, f"the code block opened at line {open_at} never closes"
    return blocks


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_fences_balance_and_links_exist(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    _fences(text)
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", prose):
        if not re.match(r"[a-z]+://", target):
            assert (page.parent / target).exists(), f"{page.name} links to {target}, which does not exist"
    assert "DESIGN.md" not in text


def test_contents_lists_every_section() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    contents = prose.split("## Contents", 1)[1].split("\n## ", 1)[0]
    after = prose.split("## Contents", 1)[1]
    sections = re.findall(r"^## (.+)$", after, flags=re.M)
    listed = re.findall(r"^\* \[(.+?)\]\(#", contents, flags=re.M)
    assert listed == sections


def test_the_env_reference_is_generated_from_the_docstrings() -> None:
    from kinegym.envdocs import PAGE, render

    assert PAGE.read_text(encoding="utf-8") == render(), "run python -m kinegym.envdocs"


def _examples() -> list[tuple[int, str]]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    out = []
    for line_no, lang, body in _fences(text):
        if lang == "console":
            out += [(line_no, ln[2:]) for ln in body if ln.startswith("$ ")]
    return out


def test_the_shell_examples_exit_cleanly(tmp_path: Path) -> None:
    """Every ``$ command`` in the README's console blocks (not in NOT_RUN) exits 0 from a fresh
    folder, or the code its comment names (``# ...; exit 3``: an answer that does not exist)."""
    bin_dir = str(Path(sys.executable).parent)
    env = {**os.environ, "PATH": bin_dir + os.pathsep + os.environ.get("PATH", ""), "SDL_VIDEODRIVER": "dummy",
           "MPLBACKEND": "Agg"}
    shutil.copytree(ROOT / "tests" / "data", tmp_path / "tests" / "data")  # as in a clone: the real photos
    ran, failed = 0, []
    for line_no, cmd in _examples():
        if any(cmd.startswith(prefix) for prefix in NOT_RUN):
            continue
        cmd, _, comment = cmd.partition("  #")  # the README's trailing comments; "exit N" says the code expected
        want = int(m.group(1)) if (m := re.search(r"\bexit (\d)\b", comment)) else 0
        res = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], cwd=tmp_path, env=env, capture_output=True,
                             text=True, timeout=300)
        ran += 1
        if res.returncode != want:
            failed.append(f"README line {line_no}: {cmd} -> exit {res.returncode}: {res.stderr[-300:]}")
    assert not failed, "\n".join(failed)
    assert ran >= 15


def test_the_quick_start_runs(tmp_path: Path) -> None:
    """The Quick start's Python blocks, each in a fresh interpreter, as a newcomer pastes them."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    quick = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    blocks = [body for _, lang, body in _fences(quick) if lang == "python"]
    assert len(blocks) == 3
    for body in blocks:
        res = subprocess.run([sys.executable, "-c", "\n".join(body)], cwd=tmp_path, capture_output=True, text=True,
                             timeout=600, env={**os.environ, "SDL_VIDEODRIVER": "dummy"})
        assert res.returncode == 0, res.stderr[-2000:]
