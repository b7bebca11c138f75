"""Optional packages: imported where a feature needs one, named with its extra if absent.

pdmkit's core install runs features, ranking, classification, sensor comparison,
monitoring and the non-neural RUL models (``pdmkit demo`` too). Some features need more:

* torch (``pip install 'pdmkit[neural]'``): the neural RUL model, torch model files,
  :func:`pdmkit.models.linearize` and ``estimate_parameters(jacobian="autograd")``;
* Dask (``pip install 'pdmkit[dask]'``): ``--workers`` / ``--scheduler`` (a cluster);
* Starlette, uvicorn and plotly (``pip install 'pdmkit[designer]'``): ``pdmkit designer``.

``pdmkit[all]`` installs them all. A module that uses one imports it inside the function
that needs it, through :func:`require`, so that a missing one is one line naming the
extra, not a traceback.

Examples
--------
>>> from pdmkit._optional import EXTRAS
>>> EXTRAS["torch"]
('torch', 'neural')
"""

from importlib import import_module as _import_module
from types import ModuleType as _ModuleType

from pdmkit.errors import MissingExtraError

__all__ = ["EXTRAS", "require"]

#: top-level import name -> (what pip installs, the pdmkit extra that installs it)
EXTRAS: dict[str, tuple[str, str]] = {
    "torch": ("torch", "neural"),
    "dask": ("dask", "dask"),
    "distributed": ("dask[distributed]", "dask"),
    "starlette": ("starlette", "designer"),
    "uvicorn": ("uvicorn", "designer"),
    "plotly": ("plotly", "designer"),
}


def require(module: str, *, what: str) -> _ModuleType:
    """Import ``module`` (a package of :data:`EXTRAS` or one of its modules) for ``what``.

    Parameters
    ----------
    module : str
        The module to import, e.g. ``"torch"`` or ``"distributed"``.
    what : str
        The feature that needs it, as the error message's subject (e.g. ``"the neural
        RUL model"``).

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    MissingExtraError
        The package is not installed: one line naming ``what``, the package and the
        ``pip install 'pdmkit[extra]'`` that brings it. A package that is installed but
        fails to import (one of its own dependencies missing) raises its own error.

    Examples
    --------
    >>> import sys
    >>> from pdmkit._optional import require
    >>> saved = sys.modules.get("torch")
    >>> sys.modules["torch"] = None  # as if torch were not installed
    >>> try:
    ...     require("torch", what="the LSTM")
    ... finally:
    ...     del sys.modules["torch"]
    ...     if saved is not None:
    ...         sys.modules["torch"] = saved
    Traceback (most recent call last):
    ...
    pdmkit.errors.MissingExtraError: the LSTM needs torch: pip install 'pdmkit[neural]'
    """
    top = module.partition(".")[0]
    if top not in EXTRAS:
        raise ValueError(f"require: {module!r} is not an optional package of pdmkit")
    package, extra = EXTRAS[top]
    try:
        return _import_module(module)
    except ModuleNotFoundError as exc:
        missing = exc.name or ""
        ours = module == missing or module.startswith(missing + ".")
        if not ours and EXTRAS.get(missing.partition(".")[0], ("", ""))[1] != extra:
            raise  # the package is there; something else it imports is not
        raise MissingExtraError(
            f"{what} needs {package}: pip install 'pdmkit[{extra}]'", name=top
        ) from None
