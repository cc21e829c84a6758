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
from .gp import GP  # each learner module registers its learner (services/learners/registry.py)
from .knn import KNN
from .lwpr import LWPR
from .per_output import PerOutput
from .registry import LEARNERS, compile_kernels, make_learner, parse_learner_spec, start_upkeep, \
    stop_upkeep
from .sogp import SOGP
from .student import Student, StudentFileError, load_student, save_student

# the learner the system is wired with (deploy profiles, experiments, demo, the learner box)
DEFAULT_LEARNER = "gp"

__all__ = [
    "DEFAULT_LEARNER", "GP", "KNN", "LEARNERS", "LWPR", "Learner", "LearnerInputError", "PerOutput", "Prediction",
           "Predictions",
    "SOGP", "Student", "StudentFileError", "UnknownLearnerError", "compile_kernels", "load_student", "make_learner",
    "parse_learner_spec", "save_student", "start_upkeep", "stop_upkeep",
]
