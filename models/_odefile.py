"""User ODE models: the model-file contract and its loader.

A model file is plain Python (no pdmkit import needed) that defines::

    STATES = {"x": "position", "v": "velocity"}   # state name -> physical kind
    INPUTS = {"F": "force"}                       # input name -> kind
    OUTPUTS = ["x"]                               # measured states
    PARAMS = {"m": 1.2, "c": 3.0, "k": 400.0}     # nominal values
    FREE = ["c"]                                  # re-estimable parameters (optional)
    INITIAL = {"x": 0.0, "v": 0.0}                # optional; default zeros

    def rhs(t, x, u, p):                          # dicts in, dict of derivatives out
        return {"x": x["v"], "v": (u["F"] - p["c"] * x["v"] - p["k"] * x["x"]) / p["m"]}

:func:`load_model_file` executes the file and checks every part of the contract, raising
:class:`~pdmkit.errors.ModelError` with a message that names the file and the problem.
An :class:`OdeModel` can also be built directly in Python.
"""

from __future__ import annotations

import inspect
import math
import os
import traceback
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pdmkit.errors import ModelError

__all__ = ["KINDS", "OdeModel", "load_model_file"]

#: The physical kinds a state or input may declare.
KINDS = (
    "position",
    "velocity",
    "angle",
    "angular_velocity",
    "level",
    "pressure",
    "temperature",
    "flow",
    "force",
    "torque",
    "voltage",
    "current",
    "other",
)


def _where(origin: str | None) -> str:
    return f"model file {origin}" if origin and origin.endswith(".py") else "model"


def _user_frame(exc: BaseException, origin: str | None) -> str:
    """``' (line N: code)'`` for the deepest traceback frame inside the model file."""
    if not origin:
        return ""
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename == origin]
    if not frames:
        return ""
    f = frames[-1]
    code = f" `{f.line.strip()}`" if f.line else ""
    return f" (line {f.lineno}:{code})"


def _check_names(where: str, what: str, names: Sequence[str]) -> None:
    for n in names:
        if not isinstance(n, str) or not n.isidentifier():
            raise ModelError(
                f"{where}: {what} names must be Python identifiers (strings); got {n!r}."
            )


def _check_kinds(where: str, what: str, mapping: Any, allow_empty: bool) -> dict[str, str]:
    if not isinstance(mapping, Mapping):
        raise ModelError(
            f"{where}: {what} must be a dict of name -> kind, e.g. "
            f'{{"x": "position"}}; got {type(mapping).__name__}.'
        )
    if not mapping and not allow_empty:
        raise ModelError(f"{where}: {what} is empty; declare at least one {what[:-1]}.")
    out = {}
    _check_names(where, what, list(mapping))
    for name, kind in mapping.items():
        if kind not in KINDS:
            raise ModelError(
                f"{where}: {what}[{name!r}] has unknown kind {kind!r}; choose one of "
                f"{', '.join(KINDS)}."
            )
        out[name] = kind
    return out


def _finite_float(where: str, label: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: {label} must be a number; got {value!r}.") from None
    if not math.isfinite(v):
        raise ModelError(f"{where}: {label} must be finite; got {v}.")
    return v


class OdeModel:
    """An ODE model ``dx/dt = rhs(t, x, u, p)`` with named, typed states and inputs.

    The right-hand side takes dicts (state name -> value, input name -> value, parameter
    name -> value) and returns a dict of time derivatives, one per state. Values may be
    floats, numpy arrays or torch tensors (element-wise), so pdmkit can run a batch of
    members at once and differentiate through the simulation.

    Parameters
    ----------
    states : dict of str to str
        State name -> physical kind (one of :data:`KINDS`).
    inputs : dict of str to str
        Input name -> kind; may be empty for an autonomous model.
    outputs : sequence of str
        The measured states.
    params : dict of str to float
        Nominal parameter values.
    rhs : callable
        ``rhs(t, x, u, p) -> dict`` of derivatives.
    free : sequence of str, optional
        Parameters that may be re-estimated from data; the others are trusted.
    initial : dict of str to float, optional
        Initial state (missing states start at 0).
    name : str, optional
        A label for messages and reports.
    origin : str, optional
        The file the model came from (used in error messages).

    Raises
    ------
    pdmkit.errors.ModelError
        Any part of the contract is violated; the message says which and how to fix it.

    Examples
    --------
    >>> from pdmkit.models._odefile import OdeModel
    >>> def rhs(t, x, u, p):
    ...     return {"h": (u["q"] - p["a"] * x["h"]) / p["A"]}
    >>> tank = OdeModel({"h": "level"}, {"q": "flow"}, ["h"], {"a": 0.5, "A": 2.0}, rhs,
    ...                 free=["a"])
    >>> tank
    <OdeModel 'model': states h(level); inputs q(flow); outputs h; free a>
    >>> tank.derivatives({"h": 1.0}, {"q": 2.0})
    {'h': 0.75}
    """

    def __init__(
        self,
        states: Mapping[str, str],
        inputs: Mapping[str, str],
        outputs: Sequence[str],
        params: Mapping[str, float],
        rhs: Callable,
        *,
        free: Sequence[str] = (),
        initial: Mapping[str, float] | None = None,
        name: str = "model",
        origin: str | None = None,
    ) -> None:
        where = _where(origin)
        self.origin = origin
        self.name = str(name)
        self.states = _check_kinds(where, "STATES", states, allow_empty=False)
        self.inputs = _check_kinds(where, "INPUTS", inputs, allow_empty=True)
        clash = set(self.states) & set(self.inputs)
        if clash:
            raise ModelError(
                f"{where}: {sorted(clash)} declared both in STATES and in INPUTS; rename "
                "one."
            )
        if isinstance(outputs, str) or not isinstance(outputs, Sequence):
            raise ModelError(
                f"{where}: OUTPUTS must be a list of state names, e.g. "
                f'["{next(iter(self.states))}"]; got {outputs!r}.'
            )
        outputs = list(outputs)
        if not outputs:
            raise ModelError(f"{where}: OUTPUTS is empty; list the measured states.")
        for o in outputs:
            if o not in self.states:
                raise ModelError(
                    f"{where}: OUTPUTS names {o!r}, which is not in STATES "
                    f"({', '.join(self.states)}); outputs must be measured states."
                )
        if len(set(outputs)) != len(outputs):
            raise ModelError(f"{where}: OUTPUTS lists a state twice: {outputs}.")
        self.outputs = outputs
        if not isinstance(params, Mapping):
            raise ModelError(
                f"{where}: PARAMS must be a dict of name -> nominal value; got "
                f"{type(params).__name__}."
            )
        _check_names(where, "PARAMS", list(params))
        self.params = {
            k: _finite_float(where, f"PARAMS[{k!r}]", v) for k, v in params.items()
        }
        if isinstance(free, str) or not isinstance(free, Sequence):
            raise ModelError(
                f"{where}: FREE must be a list of parameter names; got {free!r}."
            )
        for f in free:
            if f not in self.params:
                raise ModelError(
                    f"{where}: FREE names {f!r}, which is not in PARAMS "
                    f"({', '.join(self.params) or 'empty'}); add it to PARAMS with its "
                    "nominal value or remove it from FREE."
                )
        self.free = list(dict.fromkeys(free))
        initial = {} if initial is None else initial
        if not isinstance(initial, Mapping):
            raise ModelError(
                f"{where}: INITIAL must be a dict of state name -> value; got "
                f"{type(initial).__name__}."
            )
        for k in initial:
            if k not in self.states:
                raise ModelError(
                    f"{where}: INITIAL names {k!r}, which is not in STATES "
                    f"({', '.join(self.states)})."
                )
        self.initial = {
            k: _finite_float(where, f"INITIAL[{k!r}]", initial.get(k, 0.0))
            for k in self.states
        }
        if not callable(rhs):
            raise ModelError(
                f"{where}: rhs must be a function rhs(t, x, u, p); got "
                f"{type(rhs).__name__}."
            )
        try:
            n_args = len(inspect.signature(rhs).parameters)
        except (TypeError, ValueError):
            n_args = 4
        if n_args != 4:
            raise ModelError(
                f"{where}: rhs must take four arguments (t, x, u, p); it takes {n_args}."
            )
        self.rhs = rhs

    # ------------------------------------------------------------------ access
    @property
    def state_names(self) -> list[str]:
        """State names in declaration order."""
        return list(self.states)

    @property
    def input_names(self) -> list[str]:
        """Input names in declaration order."""
        return list(self.inputs)

    def __repr__(self) -> str:
        st = ", ".join(f"{k}({v})" for k, v in self.states.items())
        ins = ", ".join(f"{k}({v})" for k, v in self.inputs.items()) or "none"
        free = ", ".join(self.free) or "none"
        return (
            f"<OdeModel {self.name!r}: states {st}; inputs {ins}; outputs "
            f"{', '.join(self.outputs)}; free {free}>"
        )

    def with_params(self, **values: float) -> OdeModel:
        """A copy with some nominal parameter values replaced.

        Examples
        --------
        >>> from pdmkit.models._odefile import OdeModel
        >>> m = OdeModel({"h": "level"}, {}, ["h"], {"a": 1.0}, lambda t, x, u, p: {"h": 0})
        >>> m.with_params(a=2.0).params
        {'a': 2.0}
        """
        for k in values:
            if k not in self.params:
                raise ModelError(
                    f"{_where(self.origin)}: with_params got unknown parameter {k!r}; "
                    f"known: {', '.join(self.params)}."
                )
        return OdeModel(
            self.states,
            self.inputs,
            self.outputs,
            {**self.params, **values},
            self.rhs,
            free=self.free,
            initial=self.initial,
            name=self.name,
            origin=self.origin,
        )

    # ------------------------------------------------------------------ evaluation
    def derivatives(
        self,
        x: Mapping[str, Any],
        u: Mapping[str, Any] | None = None,
        p: Mapping[str, Any] | None = None,
        t: float = 0.0,
    ) -> dict[str, Any]:
        """Evaluate ``rhs`` with checks: missing or extra keys raise :class:`ModelError`.

        Parameters
        ----------
        x : dict
            State values (floats, arrays or tensors).
        u : dict, optional
            Input values; default all zero.
        p : dict, optional
            Parameter values; default the nominal ones.
        t : float
            Time in s.

        Returns
        -------
        dict of str to value
            ``dx/dt`` per state, in the order of :attr:`states`.

        Examples
        --------
        >>> from pdmkit.models._odefile import OdeModel
        >>> m = OdeModel({"h": "level"}, {}, ["h"], {"a": 2.0},
        ...              lambda t, x, u, p: {"h": -p["a"] * x["h"]})
        >>> m.derivatives({"h": 3.0})
        {'h': -6.0}
        """
        u = {k: 0.0 for k in self.inputs} if u is None else u
        p = self.params if p is None else p
        where = _where(self.origin)
        try:
            out = self.rhs(t, x, u, p)
        except Exception as exc:
            raise ModelError(
                f"{where}: rhs raised {type(exc).__name__}: {exc}"
                f"{_user_frame(exc, self.origin)}. rhs may use only arithmetic, abs and "
                "** on the dict values (they can be numpy arrays or torch tensors)."
            ) from exc
        if not isinstance(out, Mapping):
            raise ModelError(
                f"{where}: rhs must return a dict of state name -> derivative; it "
                f"returned {type(out).__name__}."
            )
        missing = [k for k in self.states if k not in out]
        extra = [k for k in out if k not in self.states]
        if missing or extra:
            parts = []
            if missing:
                parts.append(f"missing {missing}")
            if extra:
                parts.append(f"unknown {extra}")
            raise ModelError(
                f"{where}: rhs returned the wrong keys ({'; '.join(parts)}); it must "
                f"return exactly one derivative per state: {list(self.states)}."
            )
        return {k: out[k] for k in self.states}

    def check(self) -> OdeModel:
        """Evaluate the model at its initial state (inputs 0) and on a small batch.

        Raises :class:`ModelError` when ``rhs`` raises, returns the wrong keys, gives a
        non-finite derivative at the initial state, or fails on numpy arrays.

        Returns
        -------
        OdeModel
            ``self``.

        Examples
        --------
        >>> from pdmkit.models._odefile import OdeModel
        >>> m = OdeModel({"h": "level"}, {}, ["h"], {"a": 2.0},
        ...              lambda t, x, u, p: {"h": 1.0 / x["h"]})
        >>> m.check()
        Traceback (most recent call last):
        ...
        pdmkit.errors.ModelError: model: rhs raised ZeroDivisionError: ...
        """
        where = _where(self.origin)
        d = self.derivatives(dict(self.initial), None, dict(self.params), 0.0)
        for k, v in d.items():
            try:
                val = float(np.asarray(v, dtype=float))
            except (TypeError, ValueError):
                raise ModelError(
                    f"{where}: rhs returned a non-scalar derivative for {k!r} at the "
                    f"initial state with scalar inputs: {v!r}."
                ) from None
            if not math.isfinite(val):
                raise ModelError(
                    f"{where}: the derivative of {k!r} is {val} at the initial state "
                    f"{self.initial} with all inputs 0 (PARAMS {self.params}); check "
                    "divisions and ** of negative numbers, or set INITIAL."
                )
        n = 3
        xb = {k: np.full(n, v) for k, v in self.initial.items()}
        ub = {k: np.zeros(n) for k in self.inputs}
        pb = {k: np.full(n, v) for k, v in self.params.items()}
        db = self.derivatives(xb, ub, pb, 0.0)
        for k, v in db.items():
            shape = np.shape(v)
            if shape not in ((), (n,)):
                raise ModelError(
                    f"{where}: with arrays of {n} members, rhs returned shape {shape} for "
                    f"{k!r}; it must work element-wise (shape ({n},))."
                )
        return self


def _model_from_namespace(ns: Mapping[str, Any], origin: str, name: str) -> OdeModel:
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
    return OdeModel(
        ns["STATES"],
        ns.get("INPUTS", {}),
        ns["OUTPUTS"],
        ns["PARAMS"],
        ns["rhs"],
        free=ns.get("FREE", ()),
        initial=ns.get("INITIAL"),
        name=name,
        origin=origin,
    ).check()


def _load_source(source: str, origin: str, name: str) -> OdeModel:
    where = _where(origin)
    try:
        code = compile(source, origin, "exec")
    except SyntaxError as exc:
        raise ModelError(
            f"{where}: syntax error on line {exc.lineno}: {exc.msg}"
            + (f" `{exc.text.strip()}`" if exc.text else "")
        ) from exc
    ns: dict[str, Any] = {"__name__": "pdmkit_user_model", "__file__": origin}
    try:
        exec(code, ns)
    except Exception as exc:
        raise ModelError(
            f"{where}: running the file raised {type(exc).__name__}: {exc}"
            f"{_user_frame(exc, origin)}."
        ) from exc
    return _model_from_namespace(ns, origin, name)


def load_model_file(path: str | os.PathLike) -> OdeModel:
    """Load and check a user model file (the mismatch-discovery model contract).

    The file is executed in a fresh namespace; it must define ``STATES``, ``OUTPUTS``,
    ``PARAMS`` and ``rhs``, and may define ``INPUTS``, ``FREE`` and ``INITIAL`` (see the
    module docstring). ``rhs`` is evaluated once at the initial state with all inputs at
    0, and once on a small numpy batch.

    Parameters
    ----------
    path : str or path-like
        The ``.py`` file.

    Returns
    -------
    OdeModel

    Raises
    ------
    pdmkit.errors.ModelError
        The file is missing or malformed: a syntax error, a missing ``STATES``, an
        unknown kind, an output that is not a state, a ``FREE`` name not in ``PARAMS``,
        ``rhs`` raising (the exception and the line are shown), ``rhs`` returning the
        wrong keys, or a non-finite derivative at the initial state.

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
    >>> _ = path.write_text('STATES = {"h": "level"}\\nOUTPUTS = ["h"]\\nPARAMS = {}\\n'
    ...                     'FREE = ["a"]\\ndef rhs(t, x, u, p): return {"h": 0.0}\\n')
    >>> load_model_file(path)
    Traceback (most recent call last):
    ...
    pdmkit.errors.ModelError: model file .../tank.py: FREE names 'a', which is not in ...
    """
    p = Path(path)
    origin = str(p)
    if not origin.endswith(".py"):
        raise ModelError(
            f"model file {origin}: expected a Python file ending in .py; got {p.suffix!r}."
        )
    if not p.is_file():
        raise ModelError(f"model file {origin}: not found; check the path.")
    try:
        source = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"model file {origin}: cannot be read ({exc}).") from exc
    return _load_source(source, origin, p.stem)
