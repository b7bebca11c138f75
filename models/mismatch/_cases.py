"""Concealed test cases for mismatch discovery.

The showcase models (:mod:`pdmkit.models.ode`) are written as model files, exactly
what a user would write: a mass-spring-damper, two tanks, the Cascaded Tanks
benchmark and a pneumatic piston (a hidden chamber leak or valve dead time is concealed
in it; its data come from the showcase model itself, not from the full pneumatic twin).
:func:`generate_concealed_case` simulates one of them with a hidden effect from the
candidate library (sharper than the smooth form pdmkit fits) or a term outside it
(``sparse``), adds sensor noise, and hands back the model *without* the effect, the
data and the truth, so that discovery can be scored.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._xp import NumpyNamespace
from pdmkit.models.mismatch._candidates import (
    CANDIDATE_IDS,
    CANDIDATES,
    Effect,
    Scales,
    attach_candidates,
)
from pdmkit.models.mismatch._discover import discover_mismatch
from pdmkit.models.mismatch._recording import Recording
from pdmkit.models.mismatch._sampling import _nominal_scales
from pdmkit.models.mismatch._sparse import SparseTerms, Term
from pdmkit.models.ode import (
    integrate_batch,
    load_model_source,
    showcase_model,
    showcase_source,
)

if TYPE_CHECKING:
    from collections.abc import Sequence

    import pandas as pd

    from pdmkit.models.mismatch._verdict import MismatchResult

_NP = NumpyNamespace()

__all__ = [
    "ConcealedCase",
    "example_result",
    "generate_concealed_case",
    "score_concealed_cases",
]

# ---------------------------------------------------------------------------- generator
#: effect id -> the places it is concealed: (system, attach, target, partner)
_PLACES: dict[str, list[tuple[str, str, str, str | None]]] = {
    "coulomb_friction": [("mass_spring_damper", "velocity", "v", None)],
    "stribeck_friction": [("mass_spring_damper", "velocity", "v", None)],
    "bias_force": [("mass_spring_damper", "velocity", "v", None)],
    "viscous_friction": [("mass_spring_damper", "velocity", "v", None)],
    "quadratic_drag": [("mass_spring_damper", "velocity", "v", None)],
    "asymmetric_friction": [("mass_spring_damper", "velocity", "v", None)],
    "cubic_stiffness": [("mass_spring_damper", "velocity_position", "v", "x")],
    "hysteresis": [("mass_spring_damper", "velocity_position", "v", "x")],
    "backlash": [
        ("mass_spring_damper", "velocity_position", "v", "x"),
        ("mass_spring_damper", "input", "F", None),
    ],
    "dead_time": [
        ("mass_spring_damper", "input", "F", None),
        ("two_tanks", "input", "u", None),
        ("pneumatic_piston", "input", "u", None),
    ],
    "dead_zone": [
        ("mass_spring_damper", "input", "F", None),
        ("two_tanks", "input", "u", None),
    ],
    "saturation": [
        ("mass_spring_damper", "input", "F", None),
        ("two_tanks", "input", "u", None),
        ("two_tanks", "level", "h1", None),
        ("two_tanks", "level", "h2", None),
    ],
    "input_lag": [("two_tanks", "input", "u", None)],
    "overflow": [
        ("two_tanks", "level", "h1", None),
        ("two_tanks", "level", "h1", "h2"),
        ("two_tanks", "level", "h2", None),
    ],
    "leak": [
        ("two_tanks", "level", "h1", None),
        ("two_tanks", "level", "h2", None),
        ("pneumatic_piston", "level", "pa", None),
    ],
    "sensor_offset": [
        ("mass_spring_damper", "output", "x", None),
        ("two_tanks", "output", "h1", None),
        ("two_tanks", "output", "h2", None),
    ],
    "sensor_saturation": [
        ("mass_spring_damper", "output", "x", None),
        ("two_tanks", "output", "h2", None),
    ],
    "sensor_drift": [
        ("mass_spring_damper", "output", "x", None),
        ("two_tanks", "output", "h1", None),
        ("two_tanks", "output", "h2", None),
    ],
    "sensor_gain": [
        ("mass_spring_damper", "output", "x", None),
        ("two_tanks", "output", "h1", None),
        ("two_tanks", "output", "h2", None),
    ],
    "sensor_lag": [
        ("two_tanks", "output", "h1", None),
        ("two_tanks", "output", "h2", None),
    ],
    # a constant the file holds fixed is off: the piston's dead volumes (lines the
    # datasheet does not count), the supply (a regulator set lower, a sagging line)
    "constant": [
        ("pneumatic_piston", "parameter", "v_dead", None),
        ("pneumatic_piston", "parameter", "p_supply", None),
    ],
    # physics outside the named library: the data-driven fallback must find the term
    "sparse": [("mass_spring_damper", "state", "v", None)],
}

#: the hidden term of a ``sparse`` case, by (system, target): (label, sign)
_SPARSE_TRUTH = {
    # damping that grows with the displacement (a squeeze film, a progressive damper)
    ("mass_spring_damper", "v"): ("x**2*v", -1.0),
}

#: sampling of each system: (Ts, n_samples)
_TIMING = {
    "mass_spring_damper": (0.02, 1500),
    "two_tanks": (2.0, 1200),
    "pneumatic_piston": (0.005, 1200),
}


def _excitation(system: str, n: int, ts: float, rng: np.random.Generator) -> dict:
    if system == "mass_spring_damper":
        hold = (0.1, 0.8)
        lo, hi = -40.0, 40.0
        name = "F"
    elif system == "pneumatic_piston":
        hold = (0.1, 0.6)
        lo, hi = -1.0, 1.0
        name = "u"
    else:
        hold = (40.0, 200.0)
        lo, hi = 0.5, 6.0
        name = "u"
    u = np.empty(n)
    i = 0
    while i < n:
        k = max(1, round(rng.uniform(*hold) / ts))
        u[i : i + k] = rng.uniform(lo, hi)
        i += k
    return {name: u}


def _true_params(eff: Effect, m: float, sc: Scales, model, sign: float) -> dict[str, float]:
    """Effect parameters at magnitude ``m`` in (0, 1]."""
    return _TRUE_PARAMS[eff.candidate.attach](eff, m, sc, model, sign)


def _true_velocity_params(eff: Effect, m: float, sc: Scales, model, sign: float) -> dict:
    """True parameters of a friction / force effect on a velocity."""
    t, i = eff.target, eff.id
    if i == "coulomb_friction":
        return {"a": m * sc.f_absmax[t]}
    if i == "stribeck_friction":
        return {
            "a_c": 0.5 * m * sc.f_absmax[t],
            "a_s": m * sc.f_absmax[t],
            "v_s": 0.3 * sc.x_std[t],
        }
    if i == "bias_force":
        return {"b": sign * m * sc.f_absmax[t]}
    if i == "viscous_friction":
        return {"b": 5 * m * sc.f_scale(t) / sc.x_scale(t)}
    if i == "quadratic_drag":
        return {"d": 5 * m * sc.f_scale(t) / sc.x_scale(t) ** 2}
    if i == "asymmetric_friction":
        return {"d": sign * 3 * m * sc.f_scale(t) / sc.x_scale(t)}
    raise AssertionError(i)


def _true_velocity_position_params(
    eff: Effect, m: float, sc: Scales, model, sign: float
) -> dict:
    """True parameters of a restoring-force effect on a velocity paired with a position."""
    t, i = eff.target, eff.id
    if i == "hysteresis":  # Bouc-Wen: z saturates near 1 / beta, a third of the swing
        k = model.params["k"] / model.params["m"]
        return {"k_h": m * k, "beta": 3.0 / sc.x_scale(eff.partner), "gamma": 0.0}
    if i == "cubic_stiffness":
        return {"k3": 5 * m * sc.f_scale(t) / sc.x_scale(eff.partner) ** 3}
    if i == "backlash":
        k = model.params["k"] / model.params["m"]
        xs = max(abs(sc.x_max[eff.partner]), abs(sc.x_min[eff.partner]))
        return {"kappa": k, "b": max(m, 1e-6) * xs}
    raise AssertionError(i)


def _true_input_params(eff: Effect, m: float, sc: Scales, model, sign: float) -> dict:
    """True parameters of an effect on an input."""
    t, i = eff.target, eff.id
    if i == "dead_time":
        return {"tau": m * 0.1 * sc.duration}
    if i == "dead_zone":
        return {"d": m * sc.u_absmax(t)}
    if i == "saturation":
        lo = sc.u_min[t] if sc.one_sided(t) else 0.0
        return {"s": sc.u_max[t] - m * (sc.u_max[t] - lo)}
    if i == "backlash":
        return {"b": m * 0.5 * (sc.u_max[t] - sc.u_min[t])}
    if i == "input_lag":
        return {"tau": max(m * 0.05 * sc.duration, sc.h)}
    raise AssertionError(i)


def _true_level_params(eff: Effect, m: float, sc: Scales, model, sign: float) -> dict:
    """True parameters of an effect on a level or pressure."""
    t, i = eff.target, eff.id
    if i == "overflow":
        out = {"cap": sc.x_max[t] - m * (sc.x_max[t] - sc.x_min[t])}
        if eff.partner:
            out["into"] = 0.5
        return out
    if i == "leak":
        return {"k": 2 * m * sc.f_scale(t) / np.sqrt(max(sc.x_max[t], 1e-12))}
    if i == "saturation":
        return {"r": sc.f_absmax[t] * (1 - 0.97 * m)}
    raise AssertionError(i)


def _true_output_params(eff: Effect, m: float, sc: Scales, model, sign: float) -> dict:
    """True parameters of a sensor effect on an output."""
    t, i = eff.target, eff.id
    if i == "sensor_offset":
        return {"offset": sign * 2 * m * sc.x_std[t]}
    if i == "sensor_saturation":  # clipped on the side the sign picks
        hi, lo = sc.x_max[t], sc.x_min[t]
        if sign > 0:
            return {"high": hi - 0.5 * m * (hi - lo), "low": -1e30}
        return {"high": 1e30, "low": lo + 0.5 * m * (hi - lo)}
    if i == "sensor_drift":
        return {"offset": 0.0, "rate": sign * 2 * m * sc.x_std[t] / sc.duration}
    if i == "sensor_gain":
        return {"gain": 1.0 + sign * 0.5 * m}
    if i == "sensor_lag":
        return {"tau": max(m * 0.05 * sc.duration, sc.h)}
    raise AssertionError(i)


def _true_state_params(eff: Effect, m: float, sc: Scales, model, sign: float) -> dict:
    """True parameters of a sparse term (the truth's norm carries the sign)."""
    if eff.id == "sparse":
        return {"c0": 5 * m}
    raise AssertionError(eff.id)


def _true_constant_params(eff: Effect, m: float, sc: Scales, model, sign: float) -> dict:
    """A constant of the file off by the factor ``(1 + m) ** sign`` (at most 2x)."""
    return {"value": float(model.params[eff.target]) * (1.0 + m) ** sign}


#: attach kind -> the true parameters of a concealed effect of that kind
_TRUE_PARAMS = {
    "velocity": _true_velocity_params,
    "velocity_position": _true_velocity_position_params,
    "input": _true_input_params,
    "level": _true_level_params,
    "output": _true_output_params,
    "state": _true_state_params,
    "parameter": _true_constant_params,
}


@dataclasses.dataclass
class ConcealedCase:
    """A generated recording with a concealed effect, and the model without it.

    Attributes
    ----------
    effect : str
        The concealed effect id, or ``"none"`` for a control.
    target : str or None
    system : str
        The showcase model used.
    params : dict
        The concealed effect's true parameters.
    true_params : dict
        The model's true parameter values (the file's free parameter is mis-set).
    strength : float
        Relative RMS change of the outputs the effect causes (RMS of the difference
        divided by the std of the output), or for a control the relative error of the
        mis-set free parameter.
    noise : float
        Sensor noise std as a fraction of each output's std.
    model : OdeModel
        The nominal model (no effect; its free parameter mis-set).
    source : str
        ``model`` as a model file.
    data : pandas.DataFrame
        ``time``, inputs, noisy outputs.

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import generate_concealed_case
    >>> case = generate_concealed_case("overflow", 0.2, seed=3)
    >>> case.system, case.effect, case.target, round(case.strength, 2)
    ('two_tanks', 'overflow', 'h1', 0.2)
    """

    effect: str
    target: str | None
    partner: str | None
    system: str
    params: dict
    true_params: dict
    strength: float
    noise: float
    model: Any
    source: str
    data: Any

    def write(self, folder: str | os.PathLike) -> dict[str, Path]:
        """Write ``model.py`` and ``data.csv`` into ``folder``; return their paths.

        Examples
        --------
        >>> import tempfile
        >>> from pdmkit.models.mismatch._cases import generate_concealed_case
        >>> paths = generate_concealed_case("none", 0.2, seed=0).write(tempfile.mkdtemp())
        >>> sorted(paths)
        ['data', 'model']
        """
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        model = folder / "model.py"
        data = folder / "data.csv"
        model.write_text(self.source, encoding="utf-8")
        self.data.to_csv(data, index=False)
        return {"model": model, "data": data}


def _sparse_truth(model, system: str, target: str, X, u, sc: Scales) -> Effect:
    """The hidden data-driven term of a ``sparse`` case (its coefficient is c0)."""
    label, sign = _SPARSE_TRUTH[system, target]
    term = Term.parse(label)
    data = {**{s: X[:, j] for j, s in enumerate(model.states)}, **u}
    phi = np.asarray(term.evaluate(np, data, data, {}), float)
    rms = max(float(np.sqrt(np.mean(phi**2))), 1e-300)
    return Effect(SparseTerms([term], [sign * sc.f_scale(target) / rms], {}), target)


def _with_params_source(source: str, params: dict[str, float]) -> str:
    import re

    text = ", ".join(f'"{k}": {v!r}' for k, v in params.items())
    return re.sub(r"^PARAMS = \{.*\}$", f"PARAMS = {{{text}}}", source, count=1, flags=re.M)


def generate_concealed_case(
    effect: str,
    strength: float,
    seed: int,
    *,
    target: str | None = None,
    system: str | None = None,
    noise: float | None = None,
    n_samples: int | None = None,
) -> ConcealedCase:
    """A random recording with one concealed effect (or none), for testing discovery.

    The effect is simulated in a sharper form than the smooth one pdmkit fits (10x
    narrower smoothing, 4x finer steps), its magnitude chosen so that it changes the
    outputs by ``strength`` (relative RMS). Excitation (random steps), the mis-set free
    parameter (±10 %; ±``strength`` for controls) and the sensor noise are random.

    Parameters
    ----------
    effect : str
        An effect id of the library, or ``"none"`` for an effect-free control whose
        free parameter is mis-set by ``strength``. ``"sparse"`` conceals a term that no
        named candidate has (damping growing with the displacement, ``x**2*v`` on the
        mass-spring-damper's ``dv/dt``), which only the data-driven fallback can name.
    strength : float
        Relative output change caused by the effect (e.g. 0.05 - 0.5).
    seed : int
        Random seed (excitation, placement, noise).
    target : str, optional
        Where to conceal it (e.g. ``"h2"``, ``"F"``); default random among the places
        the generator knows for the effect.
    system : str, optional
        Restrict the places to one showcase system (e.g. ``"pneumatic_piston"``).
    noise : float, optional
        Noise std relative to each output's std; default uniform in [0.01, 0.02].
    n_samples : int, optional
        Record length (default 1500 samples at 50 Hz for the mass-spring-damper,
        1200 at 0.5 Hz for the tanks).

    Returns
    -------
    ConcealedCase

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import generate_concealed_case
    >>> case = generate_concealed_case("coulomb_friction", 0.2, seed=0)
    >>> case.target, list(case.data.columns), case.model.free
    ('v', ['time', 'F', 'x'], ['k'])
    """
    if not (isinstance(strength, int | float) and 0 < strength < 5):
        raise ModelError(
            f"generate_concealed_case: strength must be in (0, 5); got {strength!r}."
        )
    rng = np.random.default_rng(seed)
    noise = float(rng.uniform(0.01, 0.02)) if noise is None else float(noise)
    system, place = _choose_place(effect, system, target, rng)
    true_model = showcase_model(system)
    ts, n = _TIMING[system]
    if n_samples is not None:
        if not (isinstance(n_samples, int | np.integer) and n_samples >= 50):
            raise ModelError(
                "generate_concealed_case: n_samples must be an integer >= 50; got "
                f"{n_samples!r}."
            )
        n = int(n_samples)
    time = np.arange(n) * ts
    u = _excitation(system, n, ts, rng)
    truth = _Truth.simulate(true_model, time, ts, u)
    sign = float(rng.choice([-1.0, 1.0]))
    params: dict = {}
    if place is None:
        y_clean = truth.y0
        achieved = float(strength)
    else:
        params, y_clean = _conceal(effect, place, strength, sign, truth)
        rms = np.sqrt(np.mean((y_clean - truth.y0) ** 2, axis=0))
        achieved = float(np.max(rms / truth.std))
    noisy = (
        y_clean
        + rng.normal(size=y_clean.shape) * (noise * np.std(y_clean, axis=0))[None, :]
    )
    model, source = _misset_model(true_model, system, place, strength, rng)
    import pandas as pd

    frame = pd.DataFrame({"time": time, **u})
    for j, o in enumerate(true_model.outputs):
        frame[o] = noisy[:, j]
    return ConcealedCase(
        effect=effect,
        target=None if place is None else place[2],
        partner=None if place is None else place[3],
        system=system,
        params=params,
        true_params=dict(true_model.params),
        strength=achieved,
        noise=noise,
        model=model,
        source=source,
        data=frame,
    )


def _choose_place(effect: str, system: str | None, target: str | None, rng):
    """``(system, place)``: where the effect is concealed (place None for a control)."""
    if effect == "none":
        return ["mass_spring_damper", "two_tanks"][int(rng.integers(2))], None
    if effect not in _PLACES:
        raise ModelError(
            f"generate_concealed_case: unknown effect {effect!r}; choose from "
            f"{', '.join(CANDIDATE_IDS)} or 'none'."
        )
    places = _PLACES[effect]
    if system is not None:
        places = [p for p in places if p[0] == system]
        if not places:
            raise ModelError(
                f"generate_concealed_case: {effect} is not concealed in {system!r}; "
                f"systems: {sorted({p[0] for p in _PLACES[effect]})}."
            )
    if target is not None:
        places = [p for p in places if p[2] == target]
        if not places:
            raise ModelError(
                f"generate_concealed_case: {effect} cannot be concealed at {target!r}; "
                f"places: {sorted({p[2] for p in _PLACES[effect]})}."
            )
    place = places[int(rng.integers(len(places)))]
    return place[0], place


@dataclasses.dataclass
class _Truth:
    """The effect-free truth: model, record, simulated outputs and states, scales."""

    model: Any
    time: np.ndarray
    u: dict
    X0: np.ndarray  # (1, nx) initial state
    y0: np.ndarray  # (N, n_out) outputs
    x0t: np.ndarray  # (N, nx) states
    sc: Scales
    std: np.ndarray  # (n_out,) output std
    n_sub: int = 4

    @classmethod
    def simulate(cls, true_model, time: np.ndarray, ts: float, u: dict) -> _Truth:
        """The true model without the effect along the inputs ``u`` (4 RK4 steps)."""
        values = {f"p:{k}": v for k, v in true_model.params.items()}
        values.update({f"x0:{s}": v for s, v in true_model.initial.items()})
        n_sub = 4
        X0 = np.array([[true_model.initial[s] for s in true_model.states]])
        y0, x0t = integrate_batch(
            true_model, [], [], [], time, u, dict(true_model.params), X0, n_sub, _NP, True
        )
        outputs = {o: y0[0, :, j] for j, o in enumerate(true_model.outputs)}
        rec = Recording(time, ts, u, outputs)
        sc = _nominal_scales(true_model, rec, values, n_sub)
        std = np.std(y0[0], axis=0)
        return cls(true_model, time, u, X0, y0[0], x0t[0], sc, std, n_sub)

    def outputs(self, eff: Effect, theta: list, X0, n_sub: int, quiet: bool = False):
        """Outputs ``(B, N, n_out)`` of the true model with ``eff`` (parameters ``theta``).

        ``quiet``: without floating-point warnings (a calibration that diverges).
        """
        model = self.model
        args = ([eff], theta, [None], self.time, self.u, dict(model.params), X0, n_sub)
        if not quiet:
            return integrate_batch(model, *args, _NP)[0]
        with np.errstate(all="ignore"):
            return integrate_batch(model, *args, _NP)[0]


def _conceal(effect: str, place, strength: float, sign: float, truth: _Truth):
    """``(true parameters, clean outputs)`` of an effect changing them by ``strength``.

    The effect is sharper than the fitted one (10x narrower smoothing) and simulated
    with 4x finer steps; its magnitude is calibrated on a grid at 2x finer steps.
    """
    model, sc = truth.model, truth.sc
    system, attach, tgt, partner = place
    fine = truth.n_sub * 4
    if effect == "sparse":
        eff = probe = _sparse_truth(model, system, tgt, truth.x0t, truth.u, sc)
    else:
        cand = CANDIDATES[effect, attach]
        probe = Effect(cand, tgt, partner, {})
        opts = next(
            e.options
            for e in attach_candidates(model, sc, [effect])
            if e.candidate is cand and e.target == tgt and e.partner == partner
        )
        sharp = {k: (v / 10 if k in ("eps", "w", "wf") else v) for k, v in opts.items()}
        eff = Effect(cand, tgt, partner, sharp)
    grid = np.geomspace(1e-3, 1.0, 24)
    theta = [
        {
            p: np.array([_true_params(probe, g, sc, model, sign)[p] for g in grid])
            for p in eff.param_names
        }
    ]
    # calibrate on a coarser step; the final truth below uses the fine one
    Y = truth.outputs(eff, theta, np.repeat(truth.X0, grid.size, 0), fine // 2, True)
    rel = np.sqrt(np.mean((Y - truth.y0[None]) ** 2, axis=1)) / truth.std[None, :]
    rel = np.where(np.isfinite(rel), rel, np.inf).max(axis=1)
    m = _magnitude(rel, grid, strength)
    params = _true_params(probe, m, sc, model, sign)
    th = [{p: np.array([params[p]]) for p in eff.param_names}]
    if effect == "sparse":
        ((label, coef),) = eff.candidate.raw(params).items()
        params = {"term": label, "coefficient": coef}
    y_clean = truth.outputs(eff, th, truth.X0, fine)[0]
    return params, y_clean


def _magnitude(rel: np.ndarray, grid: np.ndarray, strength: float) -> float:
    """The magnitude on ``grid`` (log-interpolated) whose change ``rel`` is ``strength``."""
    ok = np.flatnonzero(rel >= strength)
    if ok.size == 0:
        i = int(np.argmax(np.where(np.isfinite(rel), rel, -1)))
        return float(grid[i])
    if ok[0] == 0:
        return float(grid[0])
    i = int(ok[0])
    a, b = rel[i - 1], rel[i]
    f = (strength - a) / (b - a) if b > a else 1.0
    return float(np.exp(np.log(grid[i - 1]) + f * (np.log(grid[i]) - np.log(grid[i - 1]))))


def _misset_model(true_model, system: str, place, strength: float, rng):
    """``(model, source)`` given to discovery: the free parameter mis-set.

    By ±10 %; in a control (no place) by ±``strength``.
    """
    free = true_model.free[0]
    if place is None:
        factor = 1.0 + float(rng.choice([-1.0, 1.0])) * float(strength)
    else:
        factor = 1.0 + float(rng.uniform(-0.1, 0.1))
    file_params = dict(true_model.params)
    file_params[free] = true_model.params[free] * factor
    source = _with_params_source(showcase_source(system), file_params)
    return load_model_source(source, name=system), source


def example_result(seed: int = 1) -> MismatchResult:
    """A small, fast :class:`~pdmkit.models.mismatch.MismatchResult` for examples.

    Discovery on a 300-sample effect-free control (:func:`generate_concealed_case`
    with ``"none"``), trying only the ``sensor_offset`` candidate: about a second.

    Parameters
    ----------
    seed : int
        Seed of the control case.

    Returns
    -------
    MismatchResult

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import example_result
    >>> example_result().verdict["effect"]
    'none'
    """
    case = generate_concealed_case("none", 0.2, seed=seed, n_samples=300)
    return discover_mismatch(case.model, case.data, effects=["sensor_offset"])


def score_concealed_cases(
    effects: Sequence[str] | None = None,
    repeats: int = 1,
    controls: int = 2,
    seed: int = 0,
    strength: tuple[float, float] = (0.05, 0.5),
    n_samples: int | None = None,
    verbose: bool = False,
    **options: Any,
) -> pd.DataFrame:
    """Run discovery on random concealed cases and score the verdicts.

    For each repeat: one case per effect (random place, strength uniform in
    ``strength``, 1-2 % noise) and ``controls`` effect-free controls (free parameter
    mis-set by 5-30 %). A case is right when the verdict names the concealed effect
    and its target (``none`` for a control).

    Parameters
    ----------
    effects : sequence of str, optional
        Effect ids to conceal (default: every id the generator knows).
    repeats, controls, seed : int
    strength : (float, float)
    n_samples : int, optional
        Record length passed to :func:`generate_concealed_case`.
    verbose : bool
        Print one line per case.
    **options
        Passed to :func:`~pdmkit.models.mismatch.discover_mismatch`
        (``candidates=`` restricts the effect ids it tries).

    Returns
    -------
    pandas.DataFrame
        One row per case: ``effect``, ``target``, ``strength``, ``seed``, ``verdict``,
        ``verdict_target``, ``also``, ``right``, ``rmse_drop``, ``seconds`` (wall
        clock) and ``cpu_seconds`` (CPU time of this process: robust to other load).

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import score_concealed_cases
    >>> tab = score_concealed_cases(["sensor_offset"], controls=1, n_samples=300,
    ...                             candidates=["sensor_offset", "sensor_gain"],
    ...                             pairs=False)
    >>> tab["right"].tolist()
    [True, True]
    """
    import time as _time

    import pandas as pd

    if "candidates" in options:
        options["effects"] = options.pop("candidates")
    effects = list(_PLACES) if effects is None else list(effects)
    rows = []
    for rep in range(repeats):
        for i, eff in enumerate([*effects, *["none"] * controls]):
            s = seed + 100 * rep + i
            rng = np.random.default_rng(10_000 + s)
            st = (
                float(rng.uniform(*strength))
                if eff != "none"
                else float(rng.uniform(0.05, 0.3))
            )
            case = generate_concealed_case(eff, st, s, n_samples=n_samples)
            t0, c0 = _time.perf_counter(), _time.process_time()
            res = discover_mismatch(case.model, case.data, **options)
            dt, cpu = _time.perf_counter() - t0, _time.process_time() - c0
            v = res.verdict
            right = v["effect"] == case.effect and (
                case.effect == "none" or v["target"] == case.target
            )
            row = {
                "effect": eff,
                "target": case.target,
                "strength": case.strength,
                "seed": s,
                "verdict": v["effect"],
                "verdict_target": v["target"],
                "also": ", ".join(
                    f"{a['effect']}@{a['target']}" for a in v.get("also", [])
                ),
                "right": bool(right),
                "rmse_drop": 1.0 - res.fit["rmse_augmented"] / res.fit["rmse_nominal"],
                "seconds": dt,
                "cpu_seconds": cpu,
            }
            rows.append(row)
            if verbose:
                print(
                    f"{'ok ' if right else 'BAD'} {eff}@{case.target} s={case.strength:.2f}"
                    f" -> {v['effect']}@{v['target']} drop={row['rmse_drop']:.2f}"
                    f" also=[{row['also']}] {dt:.1f}s (cpu {cpu:.1f}s)",
                    flush=True,
                )
    return pd.DataFrame(rows)
