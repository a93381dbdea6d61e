"""Shared test settings: headless, deterministic hypothesis profile; the bench scripts as modules
(``bench_envs``, ``bench_vision``, ``photo_conditions`` fixtures) for tests of their options and of their conditions."""

import importlib.util
import os
from pathlib import Path
from types import ModuleType

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")

import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile(
    "kinegym", max_examples=40, deadline=None, derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("kinegym")

BENCH = Path(__file__).resolve().parents[1] / "bench"


def _bench(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, BENCH / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def bench_envs() -> ModuleType:
    return _bench("bench_envs")


@pytest.fixture(scope="module")
def bench_vision() -> ModuleType:
    return _bench("bench_vision")


@pytest.fixture(scope="module")
def photo_conditions() -> ModuleType:
    return _bench("photo_conditions")
