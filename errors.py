"""The exceptions and warnings pdmkit raises.

Every exception subclasses :class:`PdmkitError` and a built-in, so ``except PdmkitError``
catches whatever pdmkit raises and ``except ValueError`` keeps working in user code.
Messages name the input (file, member, signal or parameter), what was expected, what
was found, and how to fix it.

Examples
--------
>>> from pdmkit.errors import DataError, PdmkitError
>>> issubclass(DataError, ValueError), issubclass(DataError, PdmkitError)
(True, True)
"""

import difflib as _difflib
from collections.abc import Iterable as _Iterable

__all__ = [
    "ConvergenceWarning",
    "DataError",
    "DataNotFoundError",
    "DataWarning",
    "MissingExtraError",
    "ModelError",
    "NotFittedError",  # noqa: F822 (made on first use by __getattr__)
    "PdmkitError",
    "did_you_mean",
]


class PdmkitError(Exception):
    """The base of every exception pdmkit raises (each also subclasses a built-in)."""


class DataError(PdmkitError, ValueError):
    """Input data is malformed: wrong shape, non-finite values, missing signal or column."""


class DataNotFoundError(DataError, FileNotFoundError):
    """A dataset or file could not be found where pdmkit looked for it."""


class ModelError(PdmkitError, ValueError):
    """A model (model file, parameters, structure) is malformed or inconsistent."""


class MissingExtraError(PdmkitError, ImportError):
    """A feature needs an optional package that is not installed.

    The message names the feature, the package and the ``pip install 'pdmkit[extra]'``
    that brings it (see :mod:`pdmkit._optional`); ``except ImportError`` catches it.
    """


def __getattr__(name: str):
    """``NotFittedError``, made on first use (it subclasses scikit-learn's).

    Built lazily so that ``import pdmkit.errors`` does not import scikit-learn (seconds);
    only the estimators that raise it, which import scikit-learn anyway, load it.

    Examples
    --------
    >>> from sklearn.exceptions import NotFittedError as SklearnNotFitted
    >>> from pdmkit.errors import NotFittedError
    >>> issubclass(NotFittedError, SklearnNotFitted), NotFittedError.__module__
    (True, 'pdmkit.errors')
    """
    if name != "NotFittedError":
        raise AttributeError(f"module 'pdmkit.errors' has no attribute {name!r}")
    from sklearn.exceptions import NotFittedError as _SklearnNotFittedError

    class NotFittedError(PdmkitError, _SklearnNotFittedError):
        """An estimator was used before ``fit``.

        scikit-learn's ``NotFittedError`` (a ``ValueError`` and an ``AttributeError``),
        so ``except sklearn.exceptions.NotFittedError`` catches pdmkit's too.
        """

    NotFittedError.__module__ = __name__
    NotFittedError.__qualname__ = "NotFittedError"
    globals()["NotFittedError"] = NotFittedError
    return NotFittedError


class ConvergenceWarning(RuntimeWarning):
    """An iterative fit stopped before meeting its tolerance."""


class DataWarning(UserWarning):
    """Input data was read, but not as written: pdmkit reinterpreted part of it.

    The message names the file, says what was done and how to say what was meant
    (e.g. a CSV without a header line read with generated column names).
    """


def did_you_mean(name: object, choices: _Iterable[object]) -> str:
    """The "; did you mean 'x'?" hint for an unknown name, or ``""`` when none is close.

    Parameters
    ----------
    name : object
        The name the user gave (converted with ``str``).
    choices : iterable
        The names that would have been accepted.

    Returns
    -------
    str

    Examples
    --------
    >>> from pdmkit.errors import did_you_mean
    >>> "unknown signal 'Flwo'" + did_you_mean("Flwo", ["Flow", "Position"])
    "unknown signal 'Flwo'; did you mean 'Flow'?"
    >>> did_you_mean("zzz", ["Flow"])
    ''
    """
    close = _difflib.get_close_matches(str(name), [str(c) for c in choices], n=1)
    return f"; did you mean {close[0]!r}?" if close else ""
