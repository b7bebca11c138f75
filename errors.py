"""The exceptions and warnings pdmkit raises.

Every class subclasses a built-in, so ``except ValueError`` keeps working in user code.
Messages name the input (file, member, signal or parameter), what was expected, what
was found, and how to fix it.

Examples
--------
>>> from pdmkit.errors import DataError
>>> issubclass(DataError, ValueError)
True
"""

__all__ = [
    "ConvergenceWarning",
    "DataError",
    "DataNotFoundError",
    "ModelError",
    "NotFittedError",
]


class DataError(ValueError):
    """Input data is malformed: wrong shape, non-finite values, missing signal or column."""


class DataNotFoundError(DataError, FileNotFoundError):
    """A dataset or file could not be found where pdmkit looked for it."""


class ModelError(ValueError):
    """A model (model file, parameters, structure) is malformed or inconsistent."""


class NotFittedError(ValueError, AttributeError):
    """An estimator was used before ``fit``."""


class ConvergenceWarning(RuntimeWarning):
    """An iterative fit stopped before meeting its tolerance."""
