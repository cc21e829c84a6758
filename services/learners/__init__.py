"""Learners for Dogged Learning: incremental regressors that answer with a confidence.

    from services.learners import make_learner, LEARNERS
    m = make_learner("lwpr", n_in=18, n_out=18, seed=0)
    m.learn_one(x, y); p = m.predict_one(x)   # p.y, p.confidence in [0, 1]

Importing this package is cheap: numba kernels are imported and compiled (or loaded
from numba's cache) on first use.
"""
from __future__ import annotations

from .base import Learner, Prediction, Predictions
from .errors import LearnerInputError, UnknownLearnerError
from .gp import GP
from .knn import KNN
from .lwpr import LWPR
from .per_output import PerOutput
from .sogp import SOGP

# the learner the system is wired with (deploy profiles, experiments, demo, the learner box)
DEFAULT_LEARNER = "gp"

LEARNERS: dict[str, type[Learner]] = {"lwpr": LWPR, "sogp": SOGP, "knn": KNN, "gp": GP, "per-output": PerOutput}


def make_learner(name: str, n_in: int, n_out: int, seed: int = 0, **hyper_parameters) -> Learner:
    """Build a registered learner; unknown names raise UnknownLearnerError (a KeyError),
    unknown or invalid hyper-parameters a ValueError naming the parameter."""
    try:
        cls = LEARNERS[name]
    except KeyError:
        known = ", ".join(sorted(LEARNERS))
        raise UnknownLearnerError(f"unknown learner {name!r}; known learners: {known}") from None
    accepted = cls.param_names()
    for key in hyper_parameters:
        if key not in accepted:
            raise ValueError(f"unknown hyper-parameter {key!r} for {name}; accepted: {', '.join(accepted)}")
    return cls(n_in, n_out, seed=seed, **hyper_parameters)


__all__ = [
    "DEFAULT_LEARNER", "GP", "KNN", "LEARNERS", "LWPR", "Learner", "LearnerInputError", "PerOutput", "Prediction", "Predictions",
    "SOGP", "UnknownLearnerError", "make_learner",
]
