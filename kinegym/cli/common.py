"""What every ``kinegym`` command shares: exit codes, the one-line usage error, parsing of
number lists, and the ``--json`` / text output switch.

Conventions (user-facing contract): degrees at the command line, cm for lengths; ``--json``
prints one machine-readable object; exit code 0 = done, 2 = bad input (one line naming the
value), 3 = a well-formed question with no answer (unreachable target, ...), still valid
JSON with ``--json``; 1 = a broken install (a file that ships with kinegym is missing).
This module imports only the standard library and numpy, so every command module can
import it without pulling in the others.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

__all__ = ["EXIT_OK", "EXIT_USAGE", "EXIT_NO_ANSWER", "EXIT_BROKEN_INSTALL", "UsageError", "Parser",
           "parse_floats", "parse_triples", "emit", "rnd", "add_json", "add_no_loop_guard", "write_text_atomic",
           "out_dir"]

EXIT_OK, EXIT_BROKEN_INSTALL, EXIT_USAGE, EXIT_NO_ANSWER = 0, 1, 2, 3


class UsageError(ValueError):
    """Bad command-line input; the message names the option and the value."""


class Parser(argparse.ArgumentParser):
    """An argparse parser whose errors are one :class:`UsageError` line, no usage dump."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message}")


#: The largest magnitude a number on the command line may have (cm, deg, gains): beyond it
#: products overflow to infinity and answers stop meaning anything.
MAX_MAGNITUDE = 1e6


def parse_floats(text: str, n: int, option: str) -> list[float]:
    """``"1,2,3"`` -> ``[1.0, 2.0, 3.0]`` with exactly ``n`` finite numbers within
    ``+-MAX_MAGNITUDE``."""
    parts = [p.strip() for p in text.split(",")]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        shape = ",".join("N" * 1 for _ in range(n))
        raise UsageError(f"{option} {text!r} is not {n} finite numbers like {shape}")
    big = [v for v in vals if abs(v) > MAX_MAGNITUDE]
    if big:
        raise UsageError(f"{option} {text!r}: {big[0]:g} is too large; expected numbers within +-{MAX_MAGNITUDE:g}")
    return vals


def parse_triples(text: str, option: str, width: int = 2) -> np.ndarray:
    """``"a,b;c,d;e,f"`` -> a (3, width) array (one group per arm)."""
    groups = [g for g in text.split(";")]
    if len(groups) != 3:
        example = ";".join([",".join(["N"] * width)] * 3)
        raise UsageError(f"{option} {text!r} is not 3 groups like {example!r}")
    return np.array([parse_floats(g, width, option) for g in groups])


def emit(args: argparse.Namespace, obj: dict[str, Any], text: str) -> None:
    """Print ``obj`` as one JSON object with ``--json``, else the human-readable ``text``."""
    if getattr(args, "json", False):
        print(json.dumps(obj))
    else:
        print(text)


def rnd(x: Any, nd: int = 6) -> Any:
    """Round floats and arrays (as lists) for JSON output; anything else unchanged."""
    if isinstance(x, np.ndarray):
        return np.round(x, nd).tolist()
    if isinstance(x, float):
        return round(x, nd)
    return x


def add_json(sp: argparse.ArgumentParser) -> None:
    """The ``--json`` switch every command has."""
    sp.add_argument("--json", action="store_true", help="print one JSON object")


def add_no_loop_guard(sp: argparse.ArgumentParser) -> None:
    """The ``--no-loop-guard`` switch of the commands that run a trained gait policy
    (:class:`kinegym.agents.policies.MaskedPolicyAgent`'s ``loop_guard``)."""
    sp.add_argument("--no-loop-guard", action="store_true",
                    help="a policy exactly as trained: without the guard that keeps it from re-entering a stance it "
                         "has already been in this climb while a move to a fresh one is offered")


def out_dir(path: str | Path, option: str = "--out") -> Path:
    """The folder ``path`` made (parents too), or a :class:`UsageError` naming ``option`` and why."""
    out = Path(path)
    for parent in [out, *out.parents]:
        if parent.exists():
            if not parent.is_dir():
                raise UsageError(f"{option} {str(out)!r}: {str(parent)!r} is a file, not a folder")
            break
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UsageError(f"{option} {str(out)!r}: the folder cannot be made ({err.strerror or err})") from None
    return out


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` all at once through the one writer,
    :func:`kinegym.configs.io.write_atomic` (its :class:`~kinegym.configs.io.FileError` names
    the path and why; the CLI exits 2)."""
    from kinegym.configs.io import write_atomic

    return write_atomic(path, text, what="output file")
