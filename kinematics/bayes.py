"""Lost start: a discrete Bayes filter over hole-triple hypotheses, grip after grip.

Built on the public interface of :class:`~kinegym.kinematics.localization.Localizer`.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import InvalidInputError
from .localization import Localizer
from .pose_fit import Candidate, Fix

__all__ = ["BayesLocalizer"]


class BayesLocalizer:
    """Lost start: a discrete Bayes filter over hole-triple hypotheses, grip after grip.

    The first grip seeds the hypotheses with every candidate that passes the gate (weights
    ``exp(-chi2/2)``, equal priors); every later grip (naming the arm that moved, or None
    for a body shift) propagates each hypothesis by a tracking step and multiplies in the
    new fit's likelihood. :attr:`fix` is the best hypothesis once it holds at least
    ``threshold`` of the probability. If every hypothesis dies, the grip starts over globally.
    """

    def __init__(self, localizer: Localizer, threshold: float = 0.999) -> None:
        if not 0.5 <= threshold < 1:
            raise InvalidInputError(f"threshold={threshold!r}; expected 0.5 <= threshold < 1")
        self.loc, self.threshold = localizer, threshold
        self.reset()

    def reset(self) -> None:
        self.hypotheses: dict[tuple[int, int, int], float] = {}
        self._last: dict[tuple[int, int, int], Candidate] = {}
        self.grips = 0
        self.restarts = 0

    def observe(self, q: object, moved_arm: int | None = None) -> Fix | None:
        """Add one grip; returns the :class:`Fix` once localised, else None."""
        if moved_arm is not None and moved_arm not in (1, 2, 3):
            raise InvalidInputError(f"moved_arm={moved_arm!r}; expected 1, 2, 3 or None")
        loc = self.loc
        hx, hy, cov, w = loc.measure(q)
        self.grips += 1
        new: dict[tuple[int, int, int], float] = {}
        last: dict[tuple[int, int, int], Candidate] = {}
        for holes, weight in self.hypotheses.items():
            for c in loc.track_candidates(holes, hx, hy, cov, w, moved_arm):
                if loc.passes(c, hx, hy):
                    new[c.holes] = new.get(c.holes, 0.0) + weight * math.exp(-0.5 * c.chi2)
                    last[c.holes] = c
        if not new:  # first grip, or every hypothesis died: start over from this grip
            if self.hypotheses:
                self.restarts += 1
            verts, pose, chi2, res = loc.search_measured(hx, hy, cov, w)
            limit = loc.noise.chi2_limit
            n = len(chi2) if loc.noise.tolerance is not None else int(np.searchsorted(chi2, limit, "right"))
            for i in range(n):
                c = loc.candidate(verts[i], *pose[i], chi2[i], res[i])
                if loc.passes(c, hx, hy):
                    new[c.holes] = math.exp(-0.5 * (c.chi2 - chi2[0]))
                    last[c.holes] = c
        total = sum(new.values())
        self.hypotheses = {k: v / total for k, v in new.items()} if total > 0 else {}
        self._last = last
        return self.fix

    @property
    def posterior(self) -> list[tuple[Candidate, float]]:
        """Hypotheses with their probabilities, most likely first."""
        return sorted(((self._last[k], p) for k, p in self.hypotheses.items()), key=lambda t: -t[1])

    @property
    def fix(self) -> Fix | None:
        """The localisation once one hypothesis holds ``threshold`` of the probability, else None."""
        if not self.hypotheses:
            return None
        key, p = max(self.hypotheses.items(), key=lambda kv: kv[1])
        if p < self.threshold:
            return None
        b = self._last[key]
        runner = max(((self._last[k], q) for k, q in self.hypotheses.items() if k != key),
                     key=lambda t: t[1], default=(None, 0.0))[0]
        return Fix(Candidate(b.holes, b.ids, b.pose, b.chi2, b.residual_cm, p), runner, len(self.hypotheses))
