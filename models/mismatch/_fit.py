"""Simulation-error fitting of ODE models (nominal or with candidate effects).

:func:`fit_model` estimates the free parameters, the initial state and the parameters
of any attached effects by minimising the simulation error on a training part of a
recording. Internally many *jobs* (structures x starting points) are fitted at once by a
batched Levenberg-Marquardt: every iteration simulates, in one batched RK4 pass, each
job's trial point together with the finite-difference perturbations that give its
Jacobian. Positive parameters are optimised in log space; all have bounds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models.mismatch._candidates import Effect, Scales
from pdmkit.models.mismatch._fit_problem import (
    _effect_starts,
    _Job,
    _lm,
    _make_jobs,
    _Problem,
    _Row,
)
from pdmkit.models.mismatch._recording import Recording, make_recording, state_reading
from pdmkit.models.mismatch._sampling import (
    _choose_n_sub,
    _nominal_scales,
    choose_integrator,
)

if TYPE_CHECKING:
    from pdmkit.models.ode import OdeModel

#: half the sum of squares (inf when not finite), as the candidate selection reads costs

__all__ = ["FitResult", "Recording", "fit_model", "make_recording", "nominal_scales"]


# ---------------------------------------------------------------------------- public
@dataclasses.dataclass
class FitResult:
    """A fitted structure: parameter values, costs, and its simulated outputs.

    Attributes
    ----------
    effects : tuple of Effect
        The effects added to the model (empty for the nominal model).
    values : dict of str to float
        Every value: ``"p:<param>"`` model parameters, ``"x0:<state>"`` initial
        state, ``"<effect key>.<param>"`` effect parameters.
    cost : float
        Half the sum of squared weighted residuals on the fitted part.
    rmse_fit : float
        RMS output error on the fitted part (output units when there is one output;
        weighted by each output's scale otherwise).
    n_params : int
        Number of fitted values.
    n_iter : int
        Levenberg-Marquardt iterations.
    y_sim : ndarray, shape (N, n_outputs)
        Outputs simulated over the whole recording.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch._fit import fit_model
    >>> tank = showcase_model("two_tanks")
    >>> t = np.arange(100) * 2.0
    >>> fit = fit_model(tank, {"time": t, "u": 3 + 0 * t, "h1": 0.1 + 0 * t,
    ...                        "h2": 0.1 + 0 * t})
    >>> fit.key, sorted(fit.params())
    ('nominal', ['b', 'k1', 'k2'])
    """

    effects: tuple
    values: dict[str, float]
    cost: float
    rmse_fit: float
    n_params: int
    n_iter: int
    y_sim: np.ndarray | None = None
    tag: str = ""

    @property
    def key(self) -> str:
        return "+".join(e.key for e in self.effects) or "nominal"

    def params(self) -> dict[str, float]:
        """Model parameters (``p:`` entries without the prefix)."""
        return {k[2:]: v for k, v in self.values.items() if k.startswith("p:")}

    def effect_params(self) -> dict[str, float]:
        """Effect parameters keyed ``"<effect key>.<param>"``."""
        return {k: v for k, v in self.values.items() if not k.startswith(("p:", "x0:"))}


def measured_scales(model, rec: Recording) -> dict[str, float]:
    """Each state's scale: its reading's spread where an output reads it, else 1."""
    x_scale = {s: 1.0 for s in model.states}
    for s in model.states:
        y = state_reading(model, rec, s)
        if y is not None:
            x_scale[s] = float(np.std(y)) or 1.0
    return x_scale


def _initial_values(model, rec: Recording) -> dict[str, float]:
    vals = {f"p:{k}": v for k, v in model.params.items()}
    for s in model.states:
        vals[f"x0:{s}"] = model.initial[s]
    for s in model.states:
        y = state_reading(model, rec, s)
        if y is not None:
            vals[f"x0:{s}"] = float(np.mean(y[:3]))
    return vals


#: starts of the nominal fit: the file's values and this many more, each free
#: parameter drawn within a factor of ``NOMINAL_SPREAD`` of the file's value (log-uniform,
#: fixed seed). They run in one batch, so they cost little more wall time than one: a
#: fixed-step simulation of a switching model (end stops, valves) is a rough function of
#: its parameters, and one start can stall where another gets through.
NOMINAL_EXTRA_STARTS, NOMINAL_SPREAD = 5, 2.0


def nominal_starts(model, values: dict[str, float]) -> list[dict[str, float]]:
    """The file's values, then :data:`NOMINAL_EXTRA_STARTS` spread around them.

    Free parameters at zero (a friction the file leaves at zero) keep their value.
    """
    rng = np.random.default_rng(0)
    starts = [dict(values)]
    if not model.free:
        return starts
    for _ in range(NOMINAL_EXTRA_STARTS):
        v = dict(values)
        for p in model.free:
            k = f"p:{p}"
            v[k] = v[k] * float(NOMINAL_SPREAD ** rng.uniform(-1.0, 1.0))
        starts.append(v)
    return starts


#: Levenberg-Marquardt iterations of :func:`polish_whole`, and its relative decrease
#: to stop at (it starts close: on EMPS 6 iterations land where 20 do)
POLISH_ITER = 6
POLISH_FTOL = 1e-3
#: ... and the relative RMSE gain on the whole span it must make to be kept
POLISH_GAIN = 1e-3


def _whole_rmse(whole: _Problem, values: Mapping[str, float], x0: np.ndarray) -> float:
    """Weighted RMSE of the whole fitted span simulated from one initial state."""
    Y = whole.simulate([(_Row(), values, np.asarray(x0, dtype=float)[None, :])])[0]
    err = (Y - whole._y) * whole.weights  # the fitted span's data, read once
    return float(np.sqrt(np.mean(err**2))) if np.all(np.isfinite(err)) else np.inf


def polish_whole(model, problem: _Problem, job: _Job, x_scale) -> _Job:
    """A fit made in pieces, refined on the whole span simulated from one start.

    Fitting a long record in pieces (each from its own fitted initial state) keeps the
    fit from diverging, but its optimum is not the whole record's: parameters under
    which the pieces drift cheaply (the viscous friction of an axis whose position
    integrates its speed) simulate a whole record worse, and a validation recording
    is simulated whole. The fit is refined on the whole fitted span from the first
    piece's state and kept when it simulates that span better (by
    :data:`POLISH_GAIN`). Returns a job on ``problem`` with the refined parameters
    (every piece's initial state refitted, the parameters held, then evaluated with
    them free), or ``job`` unchanged.

    Measured on EMPS (examples/emps/model_coulomb.py, 6 pieces of 2337 samples): an
    outside whole-record fit (scipy) validates at 5.44 mm, the pieces' fit at 6.92 mm,
    refined 5.36 mm (Fv 202 -> 212 N s/m, the outside fit's 214), for 34 s CPU more.
    """
    if problem.n_pieces < 2 or not np.isfinite(job.cost):
        return job
    whole = _Problem(model, problem.rec, problem.n_fit, problem.weights, problem.n_sub)
    x0 = job.x0[0]
    before = _whole_rmse(whole, job.values(), x0)
    (refined,) = _make_jobs(model, (), None, [{}], job.values(), x_scale,
                            tag=job.tag, x0=job.x0[:1])  # fmt: skip
    _lm(whole, [refined], POLISH_ITER, ftol=POLISH_FTOL)
    if not _whole_rmse(whole, refined.values(), refined.x0[0]) < before * (1 - POLISH_GAIN):
        return job
    (held,) = _make_jobs(model, (), None, [{}], refined.values(), x_scale,
                         fit_free=False, tag=job.tag)  # fmt: skip
    _lm(problem, [held], POLISH_ITER, ftol=POLISH_FTOL)  # the pieces' states, held
    (out,) = _make_jobs(model, (), None, [{}], refined.values(), x_scale, tag=job.tag,
                        x0=held.x0)  # fmt: skip
    _lm(problem, [out], 0)  # its cost, residuals and Jacobian on the pieces
    return out


def fit_model(
    model: OdeModel,
    data: Recording | Any,
    *,
    effects: Sequence[Effect] = (),
    n_fit: int | None = None,
    n_sub: int | None = None,
    scales: Scales | None = None,
    start: Mapping[str, float] | None = None,
    max_iter: int = 60,
) -> FitResult:
    """Fit free parameters, initial state (and effect parameters) by simulation error.

    Parameters
    ----------
    model : OdeModel
    data : Recording or DataFrame
        The recording (a table is checked with :func:`make_recording`).
    effects : sequence of Effect, optional
        Candidate effects to include; their parameters are fitted too (needs
        ``scales``, e.g. from :func:`nominal_scales`).
    n_fit : int, optional
        Fit on the first ``n_fit`` samples (default all).
    n_sub : int, optional
        RK4 steps per sample; default chosen from the model's fastest eigenvalue.
    scales : Scales, optional
        Magnitudes for the effect guesses and bounds.
    start : dict, optional
        Starting values (``"p:k"``, ``"x0:x"``, effect parameters) overriding defaults.
    max_iter : int
        Levenberg-Marquardt iterations.

    Returns
    -------
    FitResult

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.ode._simulate import simulate_ode
    >>> from pdmkit.models.mismatch._fit import fit_model
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(400) * 0.02
    >>> F = np.repeat(np.random.default_rng(0).normal(0, 40, 40), 10)
    >>> y = simulate_ode(msd, t, {"F": F}, params={"k": 350.0}).outputs["x"][0]
    >>> fit = fit_model(msd, {"time": t, "F": F, "x": y})
    >>> round(fit.params()["k"], 3)
    350.0
    """
    rec = data if isinstance(data, Recording) else make_recording(model, data)
    n_fit = rec.n if n_fit is None else int(n_fit)
    values = _initial_values(model, rec)
    if start:
        values.update(start)
    model = choose_integrator(model, rec, values)
    if n_sub is None:
        n_sub = _choose_n_sub(model, rec, values)
    if effects and scales is None:
        raise ModelError("fit_model: effects need scales (see nominal_scales).")
    y = rec.y(model)[:n_fit]
    w = 1.0 / np.maximum(np.std(y, axis=0), 1e-12)
    problem = _Problem(model, rec, n_fit, w, n_sub)
    x_scale = {s: 1.0 for s in model.states}
    if scales is not None:
        x_scale = {s: scales.x_scale(s) for s in model.states}
    else:
        x_scale = measured_scales(model, rec)
    starts = _effect_starts(effects, scales) if effects else [{}]
    if start:
        starts = [{**s, **{k: v for k, v in start.items() if "." in k}} for s in starts]
    jobs = _make_jobs(model, tuple(effects), scales, starts, values, x_scale)
    _lm(problem, jobs, max_iter)
    best = min(jobs, key=lambda j: j.cost)
    return _result(problem, best)


def _result(problem: _Problem, job: _Job, n_full: int | None = None) -> FitResult:
    vals = job.values()
    y = problem.rec.y(problem.model)[: problem.n_fit]
    n = problem.rec.n if n_full is None else n_full
    Y = problem.simulate([(job, vals, job.x0)], n=n)[0]
    err = Y[: problem.n_fit] - y
    if y.shape[1] == 1:
        rmse = float(np.sqrt(np.mean(err**2)))
    else:
        rmse = float(np.sqrt(np.mean((err * problem.weights) ** 2)))
    return FitResult(
        effects=job.effects,
        values=vals,
        cost=job.cost,
        rmse_fit=rmse,
        n_params=job.n_fitted,
        n_iter=job.n_iter,
        y_sim=Y,
        tag=job.tag,
    )


def nominal_scales(
    model: OdeModel, data: Recording | Any, fit: FitResult, n_sub: int
) -> Scales:
    """Magnitudes of the fitted nominal trajectory, for candidate guesses and widths.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch._fit import fit_model, nominal_scales
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(200) * 0.02
    >>> F = np.repeat(np.random.default_rng(1).normal(0, 40, 20), 10)
    >>> fit = fit_model(msd, {"time": t, "F": F, "x": 0 * t})
    >>> round(nominal_scales(msd, {"time": t, "F": F, "x": 0 * t}, fit, 1).ts, 6)
    0.02
    """
    rec = data if isinstance(data, Recording) else make_recording(model, data)
    return _nominal_scales(model, rec, fit.values, n_sub)
