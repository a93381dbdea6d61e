"""The kinegym command line: the main demo, kinematics, localisation, the game, the arm and training.

One module per command group (:mod:`~kinegym.cli.demo`, :mod:`~kinegym.cli.kin`,
:mod:`~kinegym.cli.game`, :mod:`~kinegym.cli.climb`, :mod:`~kinegym.cli.arm`,
:mod:`~kinegym.cli.play`, :mod:`~kinegym.cli.train`), each adding its subcommands with
``add_parsers(sub)``; what they share (exit codes, :class:`UsageError`, parsing, ``--json``
output) is in :mod:`kinegym.cli.common`. Heavy modules (OpenCV, pymunk, torch) are imported
inside the commands, so ``kinegym --help`` is instant and ``import kinegym.cli`` stays light.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence

from kinegym.cli.common import EXIT_BROKEN_INSTALL, EXIT_NO_ANSWER, EXIT_USAGE, Parser, UsageError

__all__ = ["main", "build_parser", "UsageError"]


def build_parser() -> argparse.ArgumentParser:
    """The whole ``kinegym`` parser: every command group adds its subcommands."""
    from kinegym.cli import arm, calib, climb, demo, follow, game, gui, kin, play, servo, train

    p = Parser(prog="kinegym", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)
    for group in (demo, kin, game, climb, follow, arm, calib, servo, play, gui, train):
        group.add_parsers(sub)
    return p


def _glue_negative_values(argv: list[str]) -> list[str]:
    """``--angles -24,85;...`` -> ``--angles=-24,85;...`` (argparse would read an option)."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        nxt = argv[i + 1] if i + 1 < len(argv) else ""
        if tok.startswith("--") and "=" not in tok and len(nxt) > 1 and nxt[0] == "-" and (
            nxt[1].isdigit() or nxt[1] == "."
        ):
            out.append(f"{tok}={nxt}")
            i += 2
        else:
            out.append(tok)
            i += 1
    return out



def _check_common(args: argparse.Namespace) -> None:
    """Options many commands share, checked once: a seed is an integer in 0..2**32-1 (numpy's
    and Gymnasium's range); a count of episodes, games or trials is at least 1."""
    seed = getattr(args, "seed", None)
    if isinstance(seed, int) and not 0 <= seed < 2**32:
        raise UsageError(f"--seed {seed}; expected an integer in 0..{2**32 - 1}")
    caps = {"episodes": 10_000, "games": 100_000, "trials": 1_000_000, "evals": 2_000, "timesteps": 10**9}
    for name, cap in caps.items():
        v = getattr(args, name, None)
        if isinstance(v, int) and not 1 <= v <= cap:
            raise UsageError(f"--{name.replace('_', '-')} {v}; expected an integer in 1..{cap:,}")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code (also used by the ``kinegym`` script)."""
    from kinegym.configs import ConfigError
    from kinegym.envs.errors import InvalidActionError, NoRouteError
    from kinegym.envs.game import GameError
    from kinegym.kinematics.errors import InvalidInputError, UnreachableError
    from kinegym.vision.errors import NoBoardError, VisionError

    argv = _glue_negative_values(list(sys.argv[1:] if argv is None else argv))
    want_json = "--json" in argv
    for name in ("stdout", "stderr"):  # a closed stream (``kinegym ... >&-``): write into the void
        if getattr(sys, name) is None:
            setattr(sys, name, open(os.devnull, "w"))  # noqa: SIM115 - lives as long as the process
    from kinegym.agents.book import MissingBookError

    handlers: list[tuple[type[BaseException], int]] = [
        (MissingBookError, EXIT_BROKEN_INSTALL),
        (UsageError, EXIT_USAGE), (ConfigError, EXIT_USAGE), (InvalidInputError, EXIT_USAGE),
        (UnreachableError, EXIT_NO_ANSWER), (NoBoardError, EXIT_NO_ANSWER), (VisionError, EXIT_USAGE),
        (GameError, EXIT_USAGE), (NoRouteError, EXIT_NO_ANSWER), (InvalidActionError, EXIT_USAGE),
    ]
    try:
        args = build_parser().parse_args(argv)
        if getattr(args, "map_sigma", 0) is None:
            args.map_sigma = args.map_default
        _check_common(args)
        func: Callable[[argparse.Namespace], int] = args.func
        code = func(args)
        sys.stdout.flush()  # a closed pipe or a full disk shows here, inside the handlers below
        return code
    except BrokenPipeError:  # the reader went away (``kinegym ... | head``): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return 141  # 128 + SIGPIPE, as a shell reports it
    except tuple(h[0] for h in handlers) as exc:  # type: ignore[misc]
        code = next(c for t, c in handlers if isinstance(exc, t))
        if want_json:
            print(json.dumps({"error": type(exc).__name__, "message": str(exc),
                              **getattr(exc, "details", {})}))
        print(f"kinegym: {exc}" if not str(exc).startswith("kinegym") else str(exc), file=sys.stderr)
        return code
    except OSError as err:
        if err.filename is not None:  # a file the command opened: say which
            print(f"kinegym: {err.filename}: {err.strerror or err}", file=sys.stderr)
            return EXIT_USAGE
        try:  # the output itself cannot be written (``> /dev/full``)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            print(f"kinegym: cannot write the output ({err.strerror or err})", file=sys.stderr)
        except OSError:
            pass
        return EXIT_USAGE



if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
