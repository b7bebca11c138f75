"""Loading a model file: compile it, check it in a child process, run it here.

A model file is Python code, run with the user's rights (see
:mod:`pdmkit.models.ode._modelfile`); :func:`load_model_file` imports it first in a
child process with a time limit (``_modelfile_child.py``), then in this process, where a
``sys.exit`` from the model's code becomes a :class:`~pdmkit.errors.ModelError`.
"""

from __future__ import annotations

import functools
import linecache
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from pdmkit.errors import ModelError
from pdmkit.models.ode._modelfile import OdeModel
from pdmkit.models.ode._modelfile_checks import _user_frame
from pdmkit.models.ode._modelfile_child import (
    _STAGES,
    MODEL_TIMEOUT,
    _check_in_child,
    _check_timeout,
    _exit_message,
    _first_rows,
    _where,
)

__all__ = ["load_model_file", "load_model_source"]


def _model_from_namespace(
    ns: Mapping[str, Any], origin: str, name: str, data: Any = None
) -> OdeModel:
    where = _where(origin)
    for key in ("STATES", "OUTPUTS", "PARAMS", "rhs"):
        if key not in ns:
            hint = {
                "STATES": 'STATES = {"x": "position", "v": "velocity"}',
                "OUTPUTS": 'OUTPUTS = ["x"]',
                "PARAMS": 'PARAMS = {"m": 1.0}',
                "rhs": "def rhs(t, x, u, p): return {...}",
            }[key]
            raise ModelError(f"{where}: missing {key}; define it, e.g. `{hint}`.")
    rhs = ns["rhs"]
    out_fn = ns.get("outputs")
    if out_fn is not None and not callable(out_fn):
        raise ModelError(
            f"{where}: outputs must be a function outputs(t, x, u, p) returning a dict "
            f"of output name -> value (the names of OUTPUTS); got {type(out_fn).__name__}."
        )
    return OdeModel(
        ns["STATES"],
        ns.get("INPUTS", {}),
        ns["OUTPUTS"],
        ns["PARAMS"],
        _exit_guard(rhs, origin) if callable(rhs) else rhs,
        free=ns.get("FREE", ()),
        initial=ns.get("INITIAL"),
        name=name,
        origin=origin,
        output_fn=None if out_fn is None else _exit_guard(out_fn, origin, "outputs"),
        limits=ns.get("LIMITS"),
        integrator=ns.get("INTEGRATOR", "auto"),
    ).check(data)


def _compile(source: str, origin: str) -> Any:
    """Compile the file's text (this runs none of its code); syntax errors named.

    Text that is not a file on disk (a showcase, a string) is kept in :mod:`linecache`
    under its origin, so its functions' source can be read back (a compiled model
    translates it, :mod:`pdmkit.models.ode._compiled`).
    """
    if not os.path.isfile(origin):
        linecache.cache[origin] = (len(source), None, source.splitlines(True), origin)
    try:
        return compile(source, origin, "exec")
    except SyntaxError as exc:
        raise ModelError(
            f"{_where(origin)}: syntax error on line {exc.lineno}: {exc.msg}"
            + (f" `{exc.text.strip()}`" if exc.text else "")
        ) from exc


def _run_code(code: Any, origin: str, name: str, data: Any = None) -> OdeModel:
    """Execute a compiled model file in this process and build the checked model."""
    where = _where(origin)
    ns: dict[str, Any] = {"__name__": "pdmkit_user_model", "__file__": origin}
    try:
        exec(code, ns)
    except SystemExit as exc:
        raise ModelError(
            _exit_message(where, exc.code, _STAGES["import"], _user_frame(exc, origin))
        ) from exc
    except Exception as exc:
        raise ModelError(
            f"{where}: running the file raised {type(exc).__name__}: {exc}"
            f"{_user_frame(exc, origin)}."
        ) from exc
    return _model_from_namespace(ns, origin, name, data)


def _load_source(source: str, origin: str, name: str, data: Any = None) -> OdeModel:
    """Load model-file text in this process (no child check, no time limit)."""
    return _run_code(_compile(source, origin), origin, name, data)


def load_model_source(source: str, *, name: str = "model") -> OdeModel:
    r"""Load a model from the text of a model file, in this process.

    The text is Python code and runs here, with your rights, **without** the child
    process and time limit of :func:`load_model_file`: use it for model text you wrote
    (or generated) yourself, e.g. to ship a model to Dask workers as a string.

    Parameters
    ----------
    source : str
        The model file's text (``STATES``, ``OUTPUTS``, ``PARAMS``, ``rhs``, ...).
    name : str, default "model"
        The model's name in messages and reports.

    Returns
    -------
    OdeModel

    Raises
    ------
    pdmkit.errors.ModelError
        The text does not compile or breaks the model-file contract.

    Examples
    --------
    >>> from pdmkit.models.ode import load_model_source
    >>> text = (
    ...     'STATES = {"x": "level"}\nOUTPUTS = ["x"]\nPARAMS = {"k": 0.5}\n'
    ...     'def rhs(t, x, u, p):\n    return {"x": -p["k"] * x["x"]}\n'
    ... )
    >>> model = load_model_source(text)
    >>> model.states, model.params
    ({'x': 'level'}, {'k': 0.5})
    """
    return _load_source(source, f"<{name}>", name)


# --------------------------------------------------------------------------- exit guard
def _exit_guard(fn: Callable, origin: str, what: str = "rhs") -> Callable:
    """``fn`` (``rhs`` or ``outputs``) with a ``SystemExit`` turned into a ModelError."""
    where = _where(origin)

    @functools.wraps(fn)
    def guarded(t, x, u, p):
        try:
            return fn(t, x, u, p)
        except SystemExit as exc:
            raise ModelError(
                _exit_message(
                    where,
                    exc.code,
                    f"pdmkit was evaluating {what}",
                    _user_frame(exc, origin),
                )
            ) from exc

    return guarded


def load_model_file(
    path: str | os.PathLike,
    *,
    data: Any = None,
    model_timeout: float | None = MODEL_TIMEOUT,
) -> OdeModel:
    r"""Load and check a user model file (the mismatch-discovery model contract).

    A model file is Python code, run with your rights: it can do anything you can (read
    and write files, start programs). Trust it like code you would run.

    The file must define ``STATES``, ``OUTPUTS``, ``PARAMS`` and ``rhs``, and may define
    ``INPUTS``, ``FREE`` and ``INITIAL`` (see the module docstring). It is first
    imported in a child Python process, where ``rhs`` is evaluated at the initial state
    with all inputs 0 and with the first samples of ``data`` (and on numpy batches when
    the file imports numpy), within ``model_timeout`` seconds: a hang, a
    ``sys.exit`` / ``os._exit`` / ``quit()``, a crash or an exception there becomes a
    :class:`~pdmkit.errors.ModelError` and the child (with anything it started) is
    killed. Only then is the file executed again in a fresh namespace in this process
    and checked the same way; its top level therefore runs twice (keep side effects
    such as writing files out of it, or make them harmless to repeat). A ``sys.exit``
    from ``rhs`` later, during fitting, also becomes a ``ModelError``.

    Parameters
    ----------
    path : str or path-like
        The ``.py`` file.
    data : DataFrame or dict of array-like, optional
        The recording the model will be fitted to; ``rhs`` is also evaluated at the
        initial state with its first input samples (columns named like ``INPUTS``,
        ``time``) and must give finite derivatives of the right shape there.
    model_timeout : float or None, default 30
        Seconds the child may take to import the file and evaluate ``rhs``. None skips
        the child and loads the file in this process only (no time limit).

    Returns
    -------
    OdeModel

    Raises
    ------
    pdmkit.errors.ModelError
        The file is missing or malformed: a syntax error, a missing ``STATES``, an
        unknown kind, an output that is not a state, a ``FREE`` name not in ``PARAMS``,
        ``rhs`` raising (the exception and the line are shown), ``rhs`` returning the
        wrong keys, or a non-finite derivative at the initial state; or it did not
        return within ``model_timeout``, or called exit.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "tank.py"
    >>> _ = path.write_text('''
    ... STATES = {"h": "level"}
    ... INPUTS = {"q": "flow"}
    ... OUTPUTS = ["h"]
    ... PARAMS = {"a": 0.5}
    ... FREE = ["a"]
    ... def rhs(t, x, u, p):
    ...     return {"h": u["q"] - p["a"] * abs(x["h"]) ** 0.5}
    ... ''')
    >>> load_model_file(path)
    <OdeModel 'tank': states h(level); inputs q(flow); outputs h; free a>
    >>> _ = path.write_text('STATES = {"h": "level"}\nOUTPUTS = ["h"]\nPARAMS = {}\n'
    ...                     'FREE = ["a"]\ndef rhs(t, x, u, p): return {"h": 0.0}\n')
    >>> load_model_file(path)
    Traceback (most recent call last):
    ...
    pdmkit.errors.ModelError: model file .../tank.py: FREE names 'a', which is not in ...
    >>> _ = path.write_text('import sys\nsys.exit(0)\n')
    >>> load_model_file(path)
    Traceback (most recent call last):
    ...
    pdmkit.errors.ModelError: model file .../tank.py called exit (status 0) while ...
    """
    p = Path(path)
    origin = str(p)
    if not origin.endswith(".py"):
        raise ModelError(
            f"model file {origin}: expected a Python file ending in .py; got {p.suffix!r}."
        )
    if not p.is_file():
        raise ModelError(f"model file {origin}: not found; check the path.")
    timeout = _check_timeout(model_timeout)
    try:
        source = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"model file {origin}: cannot be read ({exc}).") from exc
    code = _compile(source, origin)
    if timeout is not None:
        _check_in_child(source, origin, _first_rows(data), timeout)
    return _run_code(code, origin, p.stem, data)
