"""MaskablePPO and VecNormalize whose every save is atomic (SB3 writes files in place), and
a MaskablePPO whose schedules can run over a time budget.

SB3's ``model.save`` and ``VecNormalize.save`` open the target and write into it; a run
killed in the middle of a checkpoint leaves a truncated ``.zip`` that ``--resume`` would then
pick. :class:`AtomicMaskablePPO` and :class:`AtomicVecNormalize` serialise to memory and hand
the bytes to :func:`kinegym.configs.io.write_atomic` (temporary file, fsync, rename), so
every checkpoint, best model and final model on disk is whole. The files are the ordinary
SB3 formats: ``sb3_contrib.MaskablePPO.load`` and ``VecNormalize.load`` read them.

SB3 moves a schedule (``learning_rate: lin_2e-4``) by the steps taken out of
``total_timesteps``; a run stopped by a time budget long before them never anneals.
While :attr:`AtomicMaskablePPO.time_budget` is set (``kinegym train --minutes``), the
schedule's progress is the budget's time left when that is less than the steps left.
"""

from __future__ import annotations

import io
import os
import pickle
import time
from pathlib import Path
from typing import Any

from sb3_contrib import MaskablePPO
from sb3_contrib.common.maskable.callbacks import MaskableEvalCallback
from stable_baselines3.common.vec_env import VecNormalize

from kinegym.configs.io import write_atomic

__all__ = ["AtomicMaskablePPO", "AtomicVecNormalize", "AtomicEvalCallback", "load_vecnormalize"]

#: What a normalisation-statistics pickle may name: numpy arrays and scalars, SB3's running
#: statistics and VecNormalize classes, spaces - no other callable is ever resolved.
_ALLOWED = {
    ("numpy", "ndarray"), ("numpy", "dtype"), ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"), ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"), ("numpy", "float64"), ("numpy", "float32"), ("numpy", "int64"),
    ("numpy", "bool_"), ("numpy.dtypes", "Float64DType"), ("numpy.dtypes", "Float32DType"),
    ("numpy.dtypes", "Int64DType"), ("numpy.dtypes", "BoolDType"), ("numpy.dtypes", "UInt8DType"),
    ("numpy.dtypes", "Int8DType"), ("numpy.dtypes", "Int32DType"),
    ("stable_baselines3.common.running_mean_std", "RunningMeanStd"),
    ("stable_baselines3.common.vec_env.vec_normalize", "VecNormalize"),
    ("kinegym.agents.atomic_save", "AtomicVecNormalize"),
    ("gymnasium.spaces.box", "Box"), ("gymnasium.spaces.discrete", "Discrete"), ("gymnasium.spaces.dict", "Dict"),
    ("numpy.random._pickle", "__randomstate_ctor"), ("numpy.random._pickle", "__generator_ctor"),
    ("numpy.random._pickle", "__bit_generator_ctor"), ("numpy.random._pcg64", "PCG64"),
    ("numpy.random._generator", "Generator"), ("collections", "OrderedDict"), ("builtins", "set"),
    ("builtins", "frozenset"), ("builtins", "slice"), ("copyreg", "_reconstructor"), ("builtins", "object"),
}


class _StatsUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in _ALLOWED:
            raise pickle.UnpicklingError(f"{module}.{name} is not allowed in normalisation statistics")
        return super().find_class(module, name)


def load_vecnormalize(path: Any, venv: Any) -> Any:
    """VecNormalize statistics from ``path`` around ``venv``, unpickled with a whitelist
    (:data:`_ALLOWED`): a file naming anything else is a ``FileError``, never run."""
    from kinegym.configs.io import FileError, read_bytes

    data = read_bytes(path, 64 << 20, "normalisation statistics (.pkl)")
    try:
        vn = _StatsUnpickler(io.BytesIO(data)).load()
    except (pickle.UnpicklingError, EOFError, AttributeError, ValueError, TypeError, IndexError) as err:
        raise FileError(path, f"not VecNormalize statistics kinegym can read safely ({err})",
                        "a vecnormalize .pkl written by kinegym train") from None
    if not isinstance(vn, VecNormalize):
        raise FileError(path, f"holds a {type(vn).__name__}", "VecNormalize statistics")
    vn.__class__ = AtomicVecNormalize
    vn.set_venv(venv)
    return vn


class AtomicMaskablePPO(MaskablePPO):
    """MaskablePPO whose :meth:`save` to a path is atomic (same archive as MaskablePPO's), and
    whose schedules end with a time budget when one is set."""

    #: ``(start, deadline)`` in ``time.monotonic()`` seconds while training runs on a time
    #: budget, else None; never saved (a loaded model runs by its steps until one is set)
    time_budget: tuple[float, float] | None = None

    def _update_current_progress_remaining(self, num_timesteps: int, total_timesteps: int) -> None:
        """SB3's progress by steps, or the time budget's share left when it is less: a linear
        schedule then reaches its end when the budget does."""
        super()._update_current_progress_remaining(num_timesteps, total_timesteps)
        if self.time_budget is not None:
            start, deadline = self.time_budget
            left = (deadline - time.monotonic()) / max(deadline - start, 1e-9)
            self._current_progress_remaining = min(self._current_progress_remaining, max(left, 0.0))

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "time_budget"]

    def save(self, path: Any, exclude: Any = None, include: Any = None) -> None:  # type: ignore[override]
        if not isinstance(path, (str, Path)):
            return super().save(path, exclude, include)
        p = Path(path)
        if not p.suffix:  # SB3 appends .zip to a bare name
            p = p.with_name(p.name + ".zip")
        buf = io.BytesIO()
        super().save(buf, exclude, include)
        write_atomic(p, buf.getvalue(), what="model file")


class AtomicEvalCallback(MaskableEvalCallback):
    """MaskableEvalCallback whose ``evaluations.npz`` is replaced atomically after each
    evaluation (SB3 rewrites it in place with ``np.savez``; the best model is saved through
    the model's own atomic :meth:`AtomicMaskablePPO.save`)."""

    def _on_step(self) -> bool:
        final = self.log_path
        if final is None:
            return super()._on_step()
        tmp = os.path.join(os.path.dirname(final), ".evaluations.tmp")
        self.log_path = tmp  # np.savez writes tmp + ".npz"
        try:
            return super()._on_step()
        finally:
            self.log_path = final
            if os.path.exists(tmp + ".npz"):
                os.replace(tmp + ".npz", final + ".npz")


class AtomicVecNormalize(VecNormalize):
    """VecNormalize whose :meth:`save` is atomic (the same pickle as VecNormalize's)."""

    def save(self, save_path: Any) -> None:  # type: ignore[override]
        write_atomic(save_path, pickle.dumps(self), what="normalisation statistics")
