"""The learners' small exception hierarchy."""
from __future__ import annotations


class LearnerInputError(ValueError):
    """An input or target of the wrong length or with a non-finite entry; the model is unchanged."""


class UnknownLearnerError(KeyError):
    """make_learner was asked for a name that is not registered."""

    def __str__(self) -> str:  # KeyError would print the repr of the message
        return str(self.args[0]) if self.args else ""
