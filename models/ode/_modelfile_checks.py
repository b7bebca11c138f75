"""Checks of the model-file contract's parts, one function per part.

Each raises :class:`~pdmkit.errors.ModelError` with a message that names the file
(``where``), the part and what was expected; :class:`~pdmkit.models.ode.OdeModel` calls
them when it is built.
"""

from __future__ import annotations

import inspect
import math
import traceback
from collections.abc import Mapping, Sequence
from typing import Any

from pdmkit.errors import ModelError

#: How a model may be integrated (``INTEGRATOR`` in a model file).
INTEGRATORS = ("auto", "rk4", "ros2")

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


def _check_outputs(
    where: str, outputs: Any, states: Mapping[str, str], has_fn: bool
) -> tuple[list[str], dict[str, str]]:
    """OUTPUTS: distinct names with a kind each; states unless ``outputs()`` is defined.

    A list names measured states (their kinds are the states'); a dict maps output name
    -> kind. Without an ``outputs(t, x, u, p)`` function every output must be a state.
    """
    if isinstance(outputs, Mapping):
        names = list(outputs)
        _check_names(where, "OUTPUTS", names)
        kinds = dict(_check_kinds(where, "OUTPUTS", outputs, allow_empty=True))
    elif isinstance(outputs, str) or not isinstance(outputs, Sequence):
        raise ModelError(
            f"{where}: OUTPUTS must be a list of state names, e.g. "
            f'["{next(iter(states))}"], or a dict of output name -> kind with a function '
            f"outputs(t, x, u, p); got {outputs!r}."
        )
    else:
        names = list(outputs)
        _check_names(where, "OUTPUTS", names)
        if len(set(names)) != len(names):
            raise ModelError(f"{where}: OUTPUTS lists a name twice: {names}.")
        kinds = {o: states.get(o, "other") for o in names}
    if not names:
        raise ModelError(f"{where}: OUTPUTS is empty; list the measured quantities.")
    if not has_fn:
        for o in names:
            if o not in states:
                raise ModelError(
                    f"{where}: OUTPUTS names {o!r}, which is not in STATES "
                    f"({', '.join(states)}); an output that is not a state needs an "
                    f"equation: define outputs(t, x, u, p) returning {{{o!r}: ...}}."
                )
    return names, kinds


def _check_limits(
    where: str, limits: Any, states: Mapping[str, str]
) -> dict[str, tuple[float, float, str | None]]:
    """LIMITS as state -> (low, high, velocity state or None): hard stops."""
    if limits is None:
        return {}
    if not isinstance(limits, Mapping):
        raise ModelError(
            f"{where}: LIMITS must be a dict of state name -> (low, high) or (low, high, "
            f'velocity state), e.g. {{"x": (0.0, 0.2, "v")}}; got {type(limits).__name__}.'
        )
    out = {}
    for s, spec in limits.items():
        if s not in states:
            raise ModelError(
                f"{where}: LIMITS names {s!r}, which is not in STATES "
                f"({', '.join(states)})."
            )
        if (
            isinstance(spec, str)
            or not isinstance(spec, Sequence)
            or len(spec) not in (2, 3)
        ):
            raise ModelError(
                f"{where}: LIMITS[{s!r}] must be (low, high) or (low, high, velocity "
                f"state); got {spec!r}."
            )
        lo = -math.inf if spec[0] is None else float(spec[0])
        hi = math.inf if spec[1] is None else float(spec[1])
        if math.isnan(lo) or math.isnan(hi) or not lo < hi:
            raise ModelError(
                f"{where}: LIMITS[{s!r}] needs low < high (None for no bound); got "
                f"({spec[0]!r}, {spec[1]!r})."
            )
        vel = spec[2] if len(spec) == 3 else None
        if vel is not None and (vel not in states or vel == s):
            raise ModelError(
                f"{where}: LIMITS[{s!r}] names velocity {vel!r}, which is not another "
                f"state ({', '.join(states)}); it is the state set to 0 when the stop is "
                "hit."
            )
        out[s] = (lo, hi, vel)
    return out


def _check_free(where: str, free: Any, params: Mapping[str, float]) -> list[str]:
    """FREE as a list of parameter names, each once."""
    if isinstance(free, str) or not isinstance(free, Sequence):
        raise ModelError(f"{where}: FREE must be a list of parameter names; got {free!r}.")
    for f in free:
        if f not in params:
            raise ModelError(
                f"{where}: FREE names {f!r}, which is not in PARAMS "
                f"({', '.join(params) or 'empty'}); add it to PARAMS with its "
                "nominal value or remove it from FREE."
            )
    return list(dict.fromkeys(free))


def _check_initial(where: str, initial: Any, states: Mapping[str, str]) -> dict[str, float]:
    """INITIAL as a finite value per state (missing states 0)."""
    initial = {} if initial is None else initial
    if not isinstance(initial, Mapping):
        raise ModelError(
            f"{where}: INITIAL must be a dict of state name -> value; got "
            f"{type(initial).__name__}."
        )
    for k in initial:
        if k not in states:
            raise ModelError(
                f"{where}: INITIAL names {k!r}, which is not in STATES "
                f"({', '.join(states)})."
            )
    return {k: _finite_float(where, f"INITIAL[{k!r}]", initial.get(k, 0.0)) for k in states}


def _check_fn(where: str, what: str, fn: Any) -> None:
    """``rhs`` / ``outputs`` must be callable with four arguments ``(t, x, u, p)``."""
    if not callable(fn):
        raise ModelError(
            f"{where}: {what} must be a function {what}(t, x, u, p); got "
            f"{type(fn).__name__}."
        )
    try:
        n_args = len(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        n_args = 4
    if n_args != 4:
        raise ModelError(
            f"{where}: {what} must take four arguments (t, x, u, p); it takes {n_args}."
        )


#: what rhs / outputs may use, said in errors
_CONTRACT_HINT = (
    "rhs and outputs may use arithmetic, abs, ** and numpy's element-wise functions "
    "(np.sqrt, np.exp, np.where, np.minimum, np.clip) on the dict values, or be written "
    "for plain numbers (math.sqrt, max/min, if/elif), which pdmkit then calls once per "
    "sample (docs/mismatch.md, 'The model file')."
)
