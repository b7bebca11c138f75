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

A model file is Python code, run with the user's rights: it can do anything the user
can. Trust it like code you would run. :func:`load_model_file` first imports it and
evaluates ``rhs`` in a child process with a time limit (``model_timeout``, 30 s), so a
file that hangs, exits or crashes there is reported as a :class:`ModelError` instead of
hanging or ending pdmkit (the child check is in ``_modelfile_child.py``); only then is
it loaded in pdmkit's own process, where a ``sys.exit`` from the model's code also
becomes a :class:`ModelError`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._xp import is_torch
from pdmkit.models.ode._compiled import CompiledModelFunction
from pdmkit.models.ode._modelfile_checks import (
    _CONTRACT_HINT,
    INTEGRATORS,
    KINDS,
    _check_fn,
    _check_free,
    _check_initial,
    _check_kinds,
    _check_limits,
    _check_names,
    _check_outputs,
    _finite_float,
    _user_frame,
)
from pdmkit.models.ode._modelfile_child import _first_rows, _where
from pdmkit.models.ode._per_sample import per_sample

__all__ = ["INTEGRATORS", "KINDS", "OdeModel"]


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
    >>> from pdmkit.models.ode._modelfile import OdeModel
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
        output_fn: Callable | None = None,
        limits: Mapping[str, Sequence] | None = None,
        integrator: str = "auto",
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
        self.outputs, self.output_kinds = _check_outputs(
            where, outputs, self.states, output_fn is not None
        )
        if output_fn is not None:
            _check_fn(where, "outputs", output_fn)
        self.output_fn = output_fn
        self.limits = _check_limits(where, limits, self.states)
        if integrator not in INTEGRATORS:
            raise ModelError(
                f"{where}: INTEGRATOR must be one of {', '.join(INTEGRATORS)}; got "
                f"{integrator!r}."
            )
        #: "rk4" (explicit), "ros2" (stiff: linearly implicit), or "auto": the fits
        #: choose from the model's fastest mode (simulate_ode takes rk4)
        self.integrator = integrator
        if not isinstance(params, Mapping):
            raise ModelError(
                f"{where}: PARAMS must be a dict of name -> nominal value; got "
                f"{type(params).__name__}."
            )
        _check_names(where, "PARAMS", list(params))
        self.params = {
            k: _finite_float(where, f"PARAMS[{k!r}]", v) for k, v in params.items()
        }
        self.free = _check_free(where, free, self.params)
        self.initial = _check_initial(where, initial, self.states)
        _check_fn(where, "rhs", rhs)
        self.rhs = rhs
        #: "batched" (rhs takes numpy arrays) or "per-sample" (rhs written for scalars,
        #: called once per member: :mod:`pdmkit.models.ode._per_sample`); set by check()
        self.evaluation = "per-sample" if getattr(rhs, "per_sample", False) else "batched"

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
        >>> from pdmkit.models.ode._modelfile import OdeModel
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
        return self.replace(params={**self.params, **values})

    def with_integrator(self, integrator: str) -> OdeModel:
        """A copy integrated with ``integrator`` (``"rk4"``, ``"ros2"`` or ``"auto"``).

        Examples
        --------
        >>> from pdmkit.models.ode._modelfile import OdeModel
        >>> m = OdeModel({"h": "level"}, {}, ["h"], {}, lambda t, x, u, p: {"h": 0.0})
        >>> m.integrator, m.with_integrator("ros2").integrator
        ('auto', 'ros2')
        """
        return self.replace(integrator=integrator)

    def replace(self, **changes: Any) -> OdeModel:
        """A copy with some constructor arguments changed (``params``, ``free``, ...).

        The copy keeps how ``rhs`` is evaluated (batched or per sample).

        Examples
        --------
        >>> from pdmkit.models.ode._modelfile import OdeModel
        >>> m = OdeModel({"h": "level"}, {}, ["h"], {"a": 1.0, "b": 2.0},
        ...              lambda t, x, u, p: {"h": 0}, free=["a"])
        >>> m.replace(free=["b"]).free
        ['b']
        """
        args = {
            "states": self.states,
            "inputs": self.inputs,
            "outputs": self.output_kinds if self.output_fn is not None else self.outputs,
            "params": self.params,
            "rhs": self.rhs,
            "free": self.free,
            "initial": self.initial,
            "name": self.name,
            "origin": self.origin,
            "output_fn": self.output_fn,
            "limits": self.limits,
            "integrator": self.integrator,
        }
        unknown = [k for k in changes if k not in args]
        if unknown:
            raise ModelError(f"OdeModel.replace: unknown arguments {unknown}.")
        args.update(changes)
        copy = OdeModel(**args)
        if copy.rhs is self.rhs:
            copy.evaluation = self.evaluation
        return copy

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
        >>> from pdmkit.models.ode._modelfile import OdeModel
        >>> m = OdeModel({"h": "level"}, {}, ["h"], {"a": 2.0},
        ...              lambda t, x, u, p: {"h": -p["a"] * x["h"]})
        >>> m.derivatives({"h": 3.0})
        {'h': -6.0}
        """
        u = {k: 0.0 for k in self.inputs} if u is None else u
        p = self.params if p is None else p
        return self._call_checked("rhs", self.rhs, list(self.states), (t, x, u, p))

    def _call_checked(self, what: str, fn: Callable, keys: list[str], args: tuple) -> dict:
        """``fn(*args)`` with its exceptions, return type and keys explained.

        ``what`` is ``"rhs"`` (one derivative per state) or ``"outputs"`` (one value per
        name of OUTPUTS).
        """
        where = _where(self.origin)
        try:
            out = fn(*args)
        except ModelError:
            raise  # already explained (e.g. the model called exit)
        except Exception as exc:
            raise ModelError(
                f"{where}: {what} raised {type(exc).__name__}: {exc}"
                f"{_user_frame(exc, self.origin)}. {_CONTRACT_HINT}"
            ) from exc
        item = "derivative" if what == "rhs" else "value"
        if not isinstance(out, Mapping):
            raise ModelError(
                f"{where}: {what} must return a dict of name -> {item}; it returned "
                f"{type(out).__name__}."
            )
        missing = [k for k in keys if k not in out]
        extra = [k for k in out if k not in keys]
        if missing or extra:
            parts = ([f"missing {missing}"] if missing else []) + (
                [f"unknown {extra}"] if extra else []
            )
            per = "state" if what == "rhs" else "name of OUTPUTS"
            raise ModelError(
                f"{where}: {what} returned the wrong keys ({'; '.join(parts)}); it must "
                f"return exactly one {item} per {per}: {keys}."
            )
        return {k: out[k] for k in keys}

    def check(self, data: Any = None) -> OdeModel:
        """Evaluate the model at its initial state (inputs 0) and on a small batch.

        Raises :class:`ModelError` when ``rhs`` raises, returns the wrong keys, gives a
        non-finite derivative at the initial state, or fails on numpy arrays. With
        ``data``, ``rhs`` is also evaluated at the initial state with the data's first
        input samples (one numpy batch): each derivative must be finite and have the
        batch's shape.

        Parameters
        ----------
        data : DataFrame or dict of array-like, optional
            A recording with one column per input (and ``time``); only its first
            samples are used. Rows with a missing or non-finite input are skipped (the
            data checks of the fit report them).

        Returns
        -------
        OdeModel
            ``self``.

        Examples
        --------
        >>> from pdmkit.models.ode._modelfile import OdeModel
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
        rows = _first_rows(data) if data is not None else []
        self._choose_evaluation(rows)
        db = self.derivatives(xb, ub, pb, 0.0)
        for k, v in db.items():
            shape = np.shape(v)
            if shape not in ((), (n,)):
                raise ModelError(
                    f"{where}: with arrays of {n} members, rhs returned shape {shape} for "
                    f"{k!r}; it must work element-wise (shape ({n},))."
                )
        if data is not None:
            self._check_first_samples(rows)
        if self.output_fn is not None:
            self._check_outputs_fn(rows)
        return self

    # ------------------------------------------------------------------ batches
    def _probe_batch(self, rows: list[dict[str, float]]) -> tuple[dict, dict, dict]:
        """A small batch of distinct members for the element-wise checks.

        The initial state, nudged a little per member, with the data's first input
        samples.
        """
        used = [r for r in rows if all(k in r for k in self.inputs)] or [{}]
        n = max(3, len(used))
        nudge = 1.0 + 1e-3 * np.arange(n)
        xb = {k: v * nudge + 1e-9 * np.arange(n) for k, v in self.initial.items()}
        ub = {
            k: np.array([used[i % len(used)].get(k, 0.0) for i in range(n)])
            for k in self.inputs
        }
        pb = {k: np.full(n, v) for k, v in self.params.items()}
        return xb, ub, pb

    def _choose_evaluation(self, rows: list[dict[str, float]]) -> None:
        """Batched when ``rhs`` takes numpy arrays element-wise, else per sample.

        A function written for plain numbers (``math.sqrt``, ``if`` on a state,
        ``max``) raises on arrays: it is then called once per member
        (:func:`~pdmkit.models.ode._per_sample.per_sample`). A batched ``rhs`` whose
        result differs from the per-member one mixes members (``np.sum`` over the
        batch, indexing): an error names the state.
        """
        fns = [("rhs", self.rhs)]
        if self.output_fn is not None:
            fns.append(("outputs", self.output_fn))
        xb, ub, pb = self._probe_batch(rows)
        where = _where(self.origin)
        for what, fn in fns:
            if getattr(fn, "per_sample", False):
                continue
            one = per_sample(fn, where, what)
            try:
                with np.errstate(all="ignore"):
                    batched = fn(0.0, dict(xb), dict(ub), dict(pb))
            except (TypeError, ValueError, ArithmeticError):
                batched = None  # written for numbers: per sample
            except ModelError:
                raise
            except Exception:
                continue  # a real error: the checks below report it with its line
            if batched is not None:
                self._compare_elementwise(what, batched, one, xb, ub, pb)
                continue
            if what == "rhs":
                self.rhs = one
            else:
                self.output_fn = one
            self.evaluation = "per-sample"
        self._compile_when_worth_it()

    def _compile_when_worth_it(self) -> None:
        """``rhs`` and ``outputs`` compiled with numba once they have cost enough time.

        See :mod:`pdmkit.models.ode._compiled`: the functions run as written until
        then, and stay so wherever the translation or the compiler does not take them.
        """
        layout = {"x": self.state_names, "u": self.input_names, "p": list(self.params)}
        fn = self.output_fn
        if not isinstance(self.rhs, CompiledModelFunction):
            outputs = (
                None if fn is None else (getattr(fn, "python", fn), list(self.outputs))
            )
            self.rhs = CompiledModelFunction(self.rhs, layout, self.state_names, outputs)
        if fn is not None and not isinstance(fn, CompiledModelFunction):
            self.output_fn = CompiledModelFunction(fn, layout, list(self.outputs))

    def _compare_elementwise(self, what, batched, one, xb, ub, pb) -> None:
        """Raise when a batched function's values differ from its per-member values."""
        if not isinstance(batched, Mapping):
            return
        try:
            with np.errstate(all="ignore"):
                alone = one(0.0, dict(xb), dict(ub), dict(pb))
        except Exception:
            return  # the scalar checks report it
        n = len(next(iter(xb.values()), [0, 0, 0]))
        for k, v in batched.items():
            if k not in alone or is_torch(v):
                continue
            try:
                a = np.broadcast_to(np.asarray(v, dtype=float), (n,))
            except (TypeError, ValueError):
                continue  # the shape checks report it
            b = np.asarray(alone[k], dtype=float)
            same = np.isclose(a, b, rtol=1e-9, atol=1e-300) | (np.isnan(a) & np.isnan(b))
            if not np.all(same):
                i = int(np.flatnonzero(~same)[0])
                raise ModelError(
                    f"{_where(self.origin)}: {what} gives {k!r} = {a[i]:.6g} for member "
                    f"{i} of a batch but {b[i]:.6g} for that member alone: it mixes the "
                    "members of a batch (np.sum, np.mean, len or indexing over the "
                    "values); write it element-wise."
                )

    # ------------------------------------------------------------------ outputs
    def output_values(
        self,
        x: Mapping[str, Any],
        u: Mapping[str, Any] | None = None,
        p: Mapping[str, Any] | None = None,
        t: Any = 0.0,
    ) -> dict[str, Any]:
        """The outputs (sensor readings) at states ``x``: ``outputs(t, x, u, p)``.

        Without an ``outputs`` function the outputs are the measured states.

        Examples
        --------
        >>> from pdmkit.models.ode._modelfile import OdeModel
        >>> m = OdeModel({"h": "level"}, {"q": "flow"}, {"h_mm": "level"}, {"a": 2.0},
        ...              lambda t, x, u, p: {"h": u["q"] - p["a"] * x["h"]},
        ...              output_fn=lambda t, x, u, p: {"h_mm": 1000.0 * x["h"]})
        >>> m.output_values({"h": 0.25}, {"q": 0.0})
        {'h_mm': 250.0}
        """
        if self.output_fn is None:
            return {o: x[o] for o in self.outputs}
        u = {k: 0.0 for k in self.inputs} if u is None else u
        p = self.params if p is None else p
        return self._call_checked("outputs", self.output_fn, self.outputs, (t, x, u, p))

    def output_states(self) -> dict[str, tuple[str, float, float]]:
        """Outputs that read one state alone, affinely: ``{output: (state, gain, offset)}``.

        ``y = gain * x[state] + offset`` with no other state or input involved (a
        position sensor in mm reading a state in m). Such outputs give the state's
        starting guesses and scales; the others (a flow computed from pressures) do not.

        Examples
        --------
        >>> from pdmkit.models.ode._modelfile import OdeModel
        >>> m = OdeModel({"x": "position", "v": "velocity"}, {}, {"x_mm": "position"},
        ...              {}, lambda t, x, u, p: {"x": x["v"], "v": -x["x"]},
        ...              output_fn=lambda t, x, u, p: {"x_mm": 1e3 * x["x"] + 5.0})
        >>> m.output_states()
        {'x_mm': ('x', 1000.0, 5.0)}
        """
        if self.output_fn is None:
            return {o: (o, 1.0, 0.0) for o in self.outputs}
        cached = getattr(self, "_output_states", None)
        if cached is not None:
            return cached
        rng = np.random.default_rng(0)
        n = 4
        x = {
            k: v + (abs(v) + 1.0) * 0.1 * rng.standard_normal(n)
            for k, v in self.initial.items()
        }
        u = {k: rng.uniform(0.0, 1.0, n) for k in self.inputs}
        p = {k: np.full(n, v) for k, v in self.params.items()}
        out: dict[str, tuple[str, float, float]] = {}
        with np.errstate(all="ignore"):
            try:
                base = self.output_values(x, u, p)
            except ModelError:
                base = {}
            for o, y0 in base.items():
                y0 = np.broadcast_to(np.asarray(y0, dtype=float), (n,))
                moved = []
                for s in [*self.states, *self.inputs]:
                    xs, us = dict(x), dict(u)
                    d = 1e-3 * (np.abs(x[s]) + 1.0) if s in x else 0.1 + 0.0 * u[s]
                    if s in x:
                        xs[s] = x[s] + d
                    else:
                        us[s] = u[s] + d
                    try:
                        y1 = np.asarray(self.output_values(xs, us, p)[o], dtype=float)
                    except ModelError:
                        moved = []
                        break
                    g = (np.broadcast_to(y1, (n,)) - y0) / d
                    if np.any(np.abs(g) > 1e-12 * (np.abs(y0) + 1.0) / d):
                        moved.append((s, g))
                if len(moved) == 1 and moved[0][0] in x:
                    s, g = moved[0]
                    gain = float(np.median(g))
                    off = y0 - gain * x[s]
                    scale = abs(gain) * float(np.max(np.abs(x[s]))) + 1e-12
                    if (
                        np.allclose(g, gain, rtol=1e-5)
                        and np.ptp(off) <= 1e-6 * scale
                        and gain != 0.0
                    ):
                        # the finite differences' rounding off (12 digits are plenty
                        # for guesses and scales)
                        off0 = float(np.median(off))
                        off0 = 0.0 if abs(off0) <= 1e-9 * scale else off0
                        out[o] = (s, float(f"{gain:.12g}"), float(f"{off0:.12g}"))
        self._output_states = out
        return out

    def _check_outputs_fn(self, rows: list[dict[str, float]]) -> None:
        """``outputs`` at the initial state: finite numbers, element-wise on a batch."""
        where = _where(self.origin)
        y = self.output_values(dict(self.initial), None, dict(self.params), 0.0)
        for k, v in y.items():
            try:
                val = float(np.asarray(v, dtype=float))
            except (TypeError, ValueError):
                raise ModelError(
                    f"{where}: outputs returned a non-scalar value for {k!r} at the "
                    f"initial state with scalar inputs: {v!r}."
                ) from None
            if not math.isfinite(val):
                raise ModelError(
                    f"{where}: output {k!r} is {val} at the initial state "
                    f"{self.initial} with all inputs 0; check divisions and ** of "
                    "negative numbers, or set INITIAL."
                )
        xb, ub, pb = self._probe_batch(rows)
        n = len(next(iter(pb.values()), np.zeros(3))) if pb else 3
        with np.errstate(all="ignore"):
            yb = self.output_values(xb, ub, pb, 0.0)
        for k, v in yb.items():
            shape = np.shape(v)
            if shape not in ((), (n,)):
                raise ModelError(
                    f"{where}: with arrays of {n} members, outputs returned shape "
                    f"{shape} for {k!r}; it must work element-wise (shape ({n},))."
                )

    def _check_first_samples(self, rows: list[dict[str, float]]) -> None:
        """``rhs`` at the initial state with the data's first input samples, batched."""
        where = _where(self.origin)
        used = [(i, r) for i, r in enumerate(rows) if all(k in r for k in self.inputs)]
        if not used:
            return
        n = len(used)
        t = used[0][1].get("time", 0.0)
        xb = {k: np.full(n, v) for k, v in self.initial.items()}
        ub = {k: np.array([r[k] for _, r in used]) for k in self.inputs}
        pb = {k: np.full(n, v) for k, v in self.params.items()}
        with np.errstate(all="ignore"):  # non-finite results are reported below
            db = self.derivatives(xb, ub, pb, t)
        for k, v in db.items():
            try:
                arr = np.asarray(v, dtype=float)
            except (TypeError, ValueError):
                raise ModelError(
                    f"{where}: rhs returned a non-numeric derivative for {k!r} at the "
                    f"initial state with the data's first input samples: {v!r}."
                ) from None
            if arr.shape not in ((), (n,)):
                raise ModelError(
                    f"{where}: with the data's first {n} input samples as arrays, rhs "
                    f"returned shape {arr.shape} for {k!r}; it must work element-wise "
                    f"(shape ({n},))."
                )
            bad = np.flatnonzero(~np.isfinite(np.broadcast_to(arr, (n,))))
            if bad.size:
                row, r = used[int(bad[0])]
                at = ", ".join(f"{name}={r[name]:g}" for name in self.inputs)
                when = f"time {r['time']:g} s, " if "time" in r else ""
                raise ModelError(
                    f"{where}: the derivative of {k!r} is "
                    f"{np.broadcast_to(arr, (n,))[bad[0]]} at the initial state "
                    f"{self.initial} with the data's input sample {row} ({when}{at}); "
                    "check divisions and ** of negative numbers, the input units, or set "
                    "INITIAL."
                )
