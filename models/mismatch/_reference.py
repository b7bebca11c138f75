"""Diagnosis by mismatch: which parameters must move to explain a faulty recording.

A model fitted on a healthy *reference* recording is the machine as it was. Given a
recording of the machine now, :func:`diagnose_change` asks which of the model's free
parameters must change to follow it (a throttle closed further: that path's valve
coefficient drops; a damper set harder: its damping rises), and whether any must.

The method, for a model with free parameters ``theta``:

1. Fit ``theta`` and the initial state on the reference (simulation error,
   Levenberg-Marquardt); its covariance from the Jacobian, inflated by the
   residual's autocorrelation time (:func:`effective_samples`: the residual of a real
   recording is never white, and an interval from white-noise theory would call every
   wiggle a change).
2. On the new recording: the reference parameters with only the initial state
   refitted (cost ``C0``); every free parameter refitted (``C1``); and each free
   parameter refitted *alone* (``C_j``): ``1 - C_j / C0`` is the share of the mismatch
   that moving parameter ``j`` alone explains.
3. A parameter has changed when it is *necessary*: held at its reference value while
   every other free parameter is refitted (cost ``C_-j``), at least ``min_share`` of
   that mismatch is what its move removes (``1 - C1 / C_-j``), significantly (an F
   test, the sample count shrunk by the residual's autocorrelation). With one free
   parameter the necessity is its share. The share alone is reported, not used to
   name: a parameter that explains much alone but that others can replace is a
   mimic, not a finding (a fault that also shifts the stroke's timing, the rig's
   damper codes recorded on another day than the reference, is explained "alone" by
   a valve coefficient that moves both, while the damper is the most necessary).
   Changed parameters are listed by necessity, then share. Every fit with one
   parameter held is restarted from the all-free fit's end with that parameter set
   back, and from the lowest fit of another parameter alone; the all-free fit from
   any nested fit that ended lower: a switching model's cost is rough, and a fit
   stopped short would make a necessity up.
   The whole recording has changed only when refitting all parameters lowers the RMSE
   by at least ``min_gain``; otherwise the verdict is "no change". A recording that has
   changed while no single parameter qualifies is "unattributed": the change is
   spread over several parameters at once, or lies outside what the free parameters
   can express; it is never reported as "no change".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._residuals import effective_samples
from pdmkit.models.mismatch._fit import _initial_values, measured_scales, nominal_starts
from pdmkit.models.mismatch._fit_problem import (
    _fd_jacobians,
    _fd_rows,
    _lm,
    _make_jobs,
    _Problem,
)
from pdmkit.models.mismatch._recording import Recording, make_recording
from pdmkit.models.mismatch._sampling import (
    _choose_n_sub,
    choose_sampling,
    converged_n_sub,
    decimate,
)

if TYPE_CHECKING:
    import pandas as pd

    from pdmkit.models.ode import OdeModel

__all__ = ["ChangeResult", "diagnose_change"]

#: two-sided normal quantile of the parameter intervals (95 %)
_Z = 1.959963984540054


@dataclasses.dataclass
class ChangeResult:
    """What moved between a reference recording and a new one.

    Attributes
    ----------
    verdict : str
        ``"changed"``, ``"no change"``, or ``"unattributed"`` (refitting every free
        parameter gains at least ``min_gain``, yet no single parameter is necessary
        to the change).
    changed_parameters : list of dict
        ``{"parameter", "reference", "value", "interval", "share", "necessity"}``,
        most necessary first: the reference fit's value, the value refitted alone on
        the new recording, its 95 % interval, the share of the mismatch it explains
        alone, and its necessity.
    parameters : list of dict
        The same for every free parameter (changed or not), with ``"changed"``.
    rmse_reference_params : float
        RMSE on the new recording with the reference parameters (initial state refitted).
    rmse_refitted : float
        RMSE on the new recording with every free parameter refitted.
    rmse_reference : float
        RMSE of the reference fit on its own recording.
    decimated : int
        Samples merged into one before fitting.
    outputs : list of str
        The fitted outputs (RMSE in their units when there is one, weighted otherwise).
    fits : dict
        Simulated outputs ``(N, n_out)`` on the new recording: ``"reference"`` (the
        reference parameters) and ``"refitted"``; ``"time"`` and ``"measured"``.

    Examples
    --------
    :func:`diagnose_change` returns one; its table has a row per free parameter:

    >>> res = ChangeResult(
    ...     verdict="changed",
    ...     changed_parameters=[],
    ...     parameters=[
    ...         {"parameter": "a", "reference": 0.5, "value": 0.35,
    ...          "interval": (0.34, 0.36), "share": 0.98, "changed": True},
    ...     ],
    ...     rmse_reference_params=0.03, rmse_refitted=0.002, rmse_reference=0.002,
    ...     decimated=1, outputs=["h"],
    ... )
    >>> res.to_pandas()[["parameter", "reference", "value", "low", "high"]]
      parameter  reference  value   low  high
    0         a        0.5   0.35  0.34  0.36
    """

    verdict: str
    changed_parameters: list[dict]
    parameters: list[dict]
    rmse_reference_params: float
    rmse_refitted: float
    rmse_reference: float
    decimated: int
    outputs: list[str]
    fits: dict[str, np.ndarray] = dataclasses.field(repr=False, default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The JSON-ready summary (without the simulated traces)."""
        return {
            "verdict": self.verdict,
            "changed_parameters": self.changed_parameters,
            "parameters": self.parameters,
            "rmse_reference_params": self.rmse_reference_params,
            "rmse_refitted": self.rmse_refitted,
            "rmse_reference": self.rmse_reference,
            "decimated": self.decimated,
            "outputs": self.outputs,
        }

    def to_pandas(self) -> pd.DataFrame:
        """One row per free parameter: reference, refitted value, interval, share."""
        import pandas as pd

        rows = [
            {
                **{k: v for k, v in p.items() if k != "interval"},
                "low": p["interval"][0],
                "high": p["interval"][1],
            }
            for p in self.parameters
        ]
        return pd.DataFrame(rows)

    def plot(self, ax=None):
        """The first output measured, with the reference and the refitted parameters."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 3))
        t = self.fits["time"]
        ax.plot(t, self.fits["measured"][:, 0], "k", lw=1, label="measured")
        ax.plot(t, self.fits["reference"][:, 0], lw=1, label="reference parameters")
        ax.plot(t, self.fits["refitted"][:, 0], lw=1, label="refitted")
        ax.set_xlabel("time (s)")
        ax.set_ylabel(self.outputs[0])
        ax.legend(loc="best", fontsize=8)
        return ax


def _model_with(model: OdeModel, free: Sequence[str], params: dict[str, float]):
    """A copy of ``model`` with other free parameters and nominal values."""
    return model.replace(free=list(free), params={**model.params, **params})


@dataclasses.dataclass
class _Fit:
    values: dict[str, float]
    cost: float
    rmse: float
    y: np.ndarray
    cov: np.ndarray | None  # of the free parameters in the optimiser's space
    names: list[str]
    log: np.ndarray


def _covariances(jobs, problem: _Problem) -> list[np.ndarray | None]:
    """Covariance of each job's parameters (optimiser space), the initial state profiled.

    The fit's own finite-difference Jacobian at the fitted point (:func:`_fd_rows`, one
    batch for every job); ``s^2 (J^T J)^-1`` with the initial state eliminated (Schur
    complement), inflated by the residual's autocorrelation time.
    """
    rows, plans = [], []
    for job in jobs:
        frows, steps, dx = _fd_rows(job, job.theta, np.asarray(job.x0, dtype=float))
        plans.append((len(rows), steps, dx))
        rows += frows
    R = problem.residuals(problem.simulate(rows))
    out = []
    for job, (r0, steps, dx) in zip(jobs, plans, strict=True):
        r, J, Jx = _fd_jacobians(R, r0, job, steps, dx)
        Jx = None if Jx is None else Jx.reshape(r.size, -1)
        out.append(_covariance(job, r, J, Jx, problem.weights.size))
    return out


def _covariance(job, r, J, Jx, n_out: int = 1) -> np.ndarray | None:
    """One job's covariance from its residual ``r`` and Jacobians ``J``, ``Jx``.

    ``s^2 (J^T J)^-1`` inflated by the residual's autocorrelation time: the samples
    over :func:`effective_samples` of the residual (``n_out`` interleaved columns),
    the same count the necessity test uses.
    """
    n = job.layout.n
    nx = 0 if Jx is None else Jx.shape[1]
    if n == 0:
        return None
    cols = r[: r.size - r.size % n_out].reshape(-1, n_out)
    cols = cols[np.all(np.isfinite(cols), axis=1)]
    tau = cols.shape[0] / effective_samples(cols) if cols.shape[0] else 1.0
    J = J if Jx is None else np.hstack([J, Jx])
    ok = np.isfinite(r) & np.all(np.isfinite(J), axis=1)
    if ok.sum() <= n + nx + 2:
        return None
    r, J = r[ok], J[ok]
    Jp, Jx = J[:, :n], J[:, n:]
    A = Jp.T @ Jp
    if job.fit_x0 and nx:
        G = Jx.T @ Jx + (1e-12 * np.trace(Jx.T @ Jx) + 1e-300) * np.eye(nx)
        A = A - Jp.T @ Jx @ np.linalg.solve(G, Jx.T @ Jp)
    s2 = float(r @ r) / max(r.size - n - nx, 1)
    return np.linalg.pinv(A) * s2 * tau


def _fits(
    model,
    rec: Recording,
    specs: Sequence[tuple[bool | Sequence[str], Sequence[dict[str, float]]]],
    max_iter: int,
    n_sub: int | None,
) -> list[_Fit]:
    """Fits of the model on ``rec``, all in one batch; the best start of each.

    ``specs``: ``(fitted, starts)`` per fit: the free parameters it fits (True: all,
    False: none, or their names; the initial state always) and the values it starts
    from (several: the one that ends lowest is kept). ``n_sub``: RK4 steps per
    sample (None: from the model's fastest mode at the first start).
    """
    y = rec.y(model)
    w = 1.0 / np.maximum(np.std(y, axis=0), 1e-12)
    if n_sub is None:
        n_sub = _choose_n_sub(model, rec, specs[0][1][0])
    problem = _Problem(model, rec, rec.n, w, n_sub)
    scales = measured_scales(model, rec)
    groups = [
        [
            job
            for start in starts
            for job in _make_jobs(model, (), None, [{}], start, scales, fit_free=fitted)
        ]
        for fitted, starts in specs
    ]
    _lm(problem, [j for g in groups for j in g], max_iter, budgeted=False)
    best = [min(g, key=lambda j: j.cost) for g in groups]
    Y = problem.simulate([(j, j.values(), j.x0) for j in best], n=rec.n)
    fits = []
    for job, Yj, cov in zip(best, Y, _covariances(best, problem), strict=True):
        err = (Yj - y) if y.shape[1] == 1 else (Yj - y) * w
        fits.append(
            _Fit(
                values=job.values(),
                cost=float(job.cost),
                rmse=float(np.sqrt(np.mean(err**2))),
                y=Yj,
                cov=cov,
                names=list(job.layout.names),
                log=np.asarray(job.layout.log, dtype=bool),
            )
        )
    return fits


def _necessity(full: _Fit, helds, y, n_free: int, alpha: float) -> list[tuple]:
    """Per free parameter ``(necessity, necessary)`` from the all-but-one refits.

    ``necessity = 1 - C_all / C_held``: the part of the mismatch left with the parameter
    held at its reference value (every other refitted) that moving it removes;
    ``necessary`` when ``(C_held - C_all) / (C_all / dof)`` exceeds the F(1, dof)
    quantile at ``1 - alpha``, ``dof`` the all-refitted residual's effective sample
    count (:func:`effective_samples`) less the parameters.

    Examples
    --------
    >>> full = _Fit({}, 1.0, 0.0, np.sin(np.arange(400.0))[:, None], None, [], None)
    >>> held = [dataclasses.replace(full, cost=c) for c in (2.0, 1.001)]
    >>> [(round(n, 3), bool(s)) for n, s in _necessity(full, held, 0 * full.y, 2, 0.05)]
    [(0.5, True), (0.001, False)]
    """
    from scipy.stats import f as f_dist

    r = (full.y - y) if full.y is not None else np.zeros((0, 1))
    dof = max(effective_samples(r) - n_free, 1.0)
    out = []
    for held in helds:
        if not (full.cost > 0 and math.isfinite(held.cost)):
            out.append((0.0, False))
            continue
        necessity = 1.0 - full.cost / held.cost if held.cost > 0 else 0.0
        F = max(held.cost - full.cost, 0.0) / (full.cost / dof)
        out.append((necessity, bool(alpha > 0 and f_dist.sf(F, 1, dof) < alpha)))
    return out


def _restarted(model, rec: Recording, full: _Fit, nested, max_iter: int, n_sub) -> _Fit:
    """The all-free fit, refitted from the best nested fit when one ended lower.

    Every fit with some parameters held is nested in the all-free one, so none can end
    below it at the optimum; one that does shows the all-free fit stopped short (a
    switching model's cost is rough), and a necessity measured against it would be
    negative. The all-free fit is then restarted from that nested fit's values (and its
    own) and the lower end kept.
    """
    best = min(nested, key=lambda f: f.cost)
    if not best.cost < full.cost * (1.0 - 1e-9):
        return full
    (again,) = _fits(model, rec, [(True, [best.values, full.values])], max_iter, n_sub)
    return again if again.cost < full.cost else full


def _restarted_helds(free, alones, helds, full, reference, fit):
    """Each all-but-one fit restarted from the points known in its space; the lower end.

    Holding parameter ``j`` at its reference and refitting the others, the fit can
    start from: its own end; the all-free fit's end with ``j`` set back to its
    reference; and the lowest fit of one other parameter alone (a point of its
    space, so the held fit cannot end above it at its optimum). A switching model's
    cost is rough, and a held fit stopped short makes ``j`` look more necessary than
    it is. Measured on the rig's sessions: bottom-damper session 1100816's damper
    necessity 0.244 -> 0.191 (its held fit had stopped short); throttle session
    1101608 unchanged (no start ended lower: its necessities hold for that basin).
    ``fit(specs)`` runs the fits in one batch (:func:`_fits`).
    """
    specs = []
    for i, name in enumerate(free):
        starts = [helds[i].values, {**full.values, f"p:{name}": reference[name]}]
        others = [a for other, a in zip(free, alones, strict=True) if other != name]
        starts.append(min(others, key=lambda f: f.cost).values)
        specs.append(([q for q in free if q != name], starts))
    return [
        again if again.cost < held.cost else held
        for held, again in zip(helds, fit(specs), strict=True)
    ]


def _interval(fit: _Fit, name: str, value: float) -> tuple[float, float, float]:
    """``(low, high, sd)`` of a parameter, sd in the optimiser's space.

    A parameter the data do not determine (a huge sd) spans ``(0, inf)`` in log space.

    Examples
    --------
    >>> fit = _Fit({}, 0.0, 0.0, None, np.diag([0.01, 1e6]), ["p:a", "p:b"],
    ...            np.array([True, True]))
    >>> [round(v, 3) for v in _interval(fit, "a", 2.0)]
    [1.644, 2.433, 0.1]
    >>> _interval(fit, "b", 2.0)[:2]
    (0.0, inf)
    """
    if fit.cov is None or f"p:{name}" not in fit.names:
        return (math.nan, math.nan, math.nan)
    i = fit.names.index(f"p:{name}")
    sd = math.sqrt(max(float(fit.cov[i, i]), 0.0))
    if fit.log[i]:
        if _Z * sd > 700.0:  # exp overflows past ~709: not determined at all
            return (0.0, math.inf, sd)
        return (value * math.exp(-_Z * sd), value * math.exp(_Z * sd), sd)
    return (value - _Z * sd, value + _Z * sd, sd)


def _reference_fit(model, rec_ref: Recording, rec: Recording, decimation, max_iter):
    """The sampling both recordings are fitted with, and the reference's fit.

    Returns ``(model, rec_ref, rec, decimation, n_sub, fit)``; ``n_sub`` None lets each
    later fit choose its step, unless the step was checked by simulation (it then holds
    for every fit, rechecked at the reference's fitted values).
    """
    sampling = choose_sampling(model, rec_ref, _initial_values(model, rec_ref))
    model = sampling.model
    if decimation is None:
        decimation = sampling.factor
    n_sub = sampling.n_sub if sampling.checked and decimation == sampling.factor else None
    if decimation > 1:
        rec_ref, rec = decimate(rec_ref, decimation), decimate(rec, decimation)
    # from several starts, as a discovery's nominal fit: a switching model's fit from
    # the file's values alone can stop in a local minimum
    starts = nominal_starts(model, _initial_values(model, rec_ref))
    (ref,) = _fits(model, rec_ref, [(True, starts)], max_iter, n_sub)
    if n_sub is not None:
        n_checked = converged_n_sub(model, rec_ref, ref.values, n_sub)
        if n_checked > n_sub:
            n_sub = n_checked
            (ref,) = _fits(model, rec_ref, [(True, [ref.values])], max_iter, n_sub)
    return model, rec_ref, rec, decimation, n_sub, ref


def diagnose_change(
    model: OdeModel,
    data: Any,
    reference: Any,
    *,
    min_gain: float = 0.2,
    min_share: float = 0.2,
    max_iter: int = 60,
    decimation: int | None = None,
    alpha: float = 0.05,
) -> ChangeResult:
    r"""Which free parameters must move from a healthy reference to explain ``data``.

    Parameters
    ----------
    model : OdeModel
        The model; its ``FREE`` parameters are the ones that may change.
    data : DataFrame, mapping or Recording
        The recording to diagnose (``time``, inputs, outputs).
    reference : DataFrame, mapping or Recording
        A recording of the machine in its reference (healthy) condition.
    min_gain : float, default 0.2
        Relative RMSE gain that refitting every free parameter on ``data`` must make
        over the reference parameters for anything to count as changed.
    min_share : float, default 0.2
        Necessity a parameter must reach to be listed as changed (with the test
        below): held at its reference value while every other parameter is refitted,
        this share of the mismatch left is what its move removes.
    alpha : float, default 0.05
        Level of the necessity test: holding the parameter leaves a significantly
        larger mismatch (an F test on the cost ratio, with the sample count shrunk by
        the residual's autocorrelation time). 0 switches the test off.
    max_iter : int, default 60
        Levenberg-Marquardt iterations per fit.
    decimation : int, optional
        Samples merged into one before fitting (default: chosen from the model's
        fastest mode and the inputs, as in :func:`discover_mismatch`).

    Returns
    -------
    ChangeResult

    Examples
    --------
    A tank whose outlet was throttled: its outflow coefficient ``a`` dropped by 30 %.

    >>> import numpy as np
    >>> from pdmkit.models.ode import load_model_source, simulate_ode
    >>> tank = load_model_source(
    ...     'import numpy as np\nSTATES = {"h": "level"}\nINPUTS = {"q": "flow"}\n'
    ...     'OUTPUTS = ["h"]\nPARAMS = {"a": 0.5, "A": 2.0}\nFREE = ["a", "A"]\n'
    ...     'INITIAL = {"h": 0.5}\n'
    ...     'def rhs(t, x, u, p):\n'
    ...     '    return {"h": (u["q"] - p["a"] * np.sqrt(np.abs(x["h"]))) / p["A"]}\n')
    >>> t = np.arange(400) * 0.5
    >>> q = np.where((t // 40) % 2 == 0, 0.6, 0.2)
    >>> rng = np.random.default_rng(0)
    >>> def record(a):
    ...     h = simulate_ode(tank, t, {"q": q}, params={"a": a}, n_sub=2).outputs["h"][0]
    ...     return {"time": t, "q": q, "h": h + rng.normal(0, 0.002, t.size)}
    >>> res = diagnose_change(tank, record(0.35), record(0.5))
    >>> res.verdict, res.changed_parameters[0]["parameter"]
    ('changed', 'a')
    >>> round(res.changed_parameters[0]["value"], 2)
    0.35
    >>> diagnose_change(tank, record(0.5), record(0.5)).verdict
    'no change'
    """
    if not model.free:
        raise ModelError(
            f"{model.name}: diagnosis by mismatch needs free parameters (FREE in the "
            "model file): the parameters that may have changed."
        )
    rec_ref = (
        reference
        if isinstance(reference, Recording)
        else make_recording(model, reference, "reference")
    )
    rec = data if isinstance(data, Recording) else make_recording(model, data, "data")
    model, rec_ref, rec, decimation, n_sub, ref = _reference_fit(
        model, rec_ref, rec, decimation, max_iter
    )
    ref_params = {k[2:]: v for k, v in ref.values.items() if k.startswith("p:")}
    start = {**_initial_values(model, rec), **{f"p:{k}": v for k, v in ref_params.items()}}
    # every fit on the new recording in one batch: the reference parameters (only the
    # initial state fitted), all free parameters, each alone, and all but each
    free = list(model.free)
    specs = [(False, [start]), (True, [start])] + [([p], [start]) for p in free]
    specs += [([q for q in free if q != p], [start]) for p in free] * (len(free) > 1)
    model_now = _model_with(model, free, ref_params)
    same, full, *rest = _fits(model_now, rec, specs, max_iter, n_sub)
    alones, helds = rest[: len(free)], rest[len(free) :] or [same]
    full = _restarted(model_now, rec, full, [*helds, *alones], max_iter, n_sub)
    if len(free) > 1:
        helds = _restarted_helds(
            free, alones, helds, full, ref_params,
            lambda specs: _fits(model_now, rec, specs, max_iter, n_sub),
        )  # fmt: skip
        full = _restarted(model_now, rec, full, helds, max_iter, n_sub)
    needed = _necessity(full, helds, rec.y(model), len(free), alpha)
    rows = []
    for name, alone, (necessity, necessary) in zip(free, alones, needed, strict=True):
        share = 1.0 - alone.cost / same.cost if same.cost > 0 else 0.0
        value = alone.values[f"p:{name}"]
        r_lo, r_hi, _ = _interval(ref, name, ref_params[name])
        lo, hi, _ = _interval(alone, name, value)
        rows.append(
            {
                "parameter": name,
                "reference": ref_params[name],
                "value": value,
                "interval": [lo, hi],
                "reference_interval": [r_lo, r_hi],
                "share": share,
                "necessity": necessity,
                "changed": False,
                "_named": necessary and necessity >= min_share,
            }
        )
    gain = 1.0 - full.rmse / same.rmse if same.rmse > 0 else 0.0
    for r in rows:
        r["changed"] = bool(gain >= min_gain and r.pop("_named"))
    rows.sort(key=lambda r: (-r["necessity"], -r["share"]))
    keys = ("parameter", "reference", "value", "interval", "share", "necessity")
    changed = [{k: r[k] for k in keys} for r in rows if r["changed"]]
    return ChangeResult(
        verdict="changed"
        if changed
        else ("unattributed" if gain >= min_gain else "no change"),
        changed_parameters=changed,
        parameters=rows,
        rmse_reference_params=same.rmse,
        rmse_refitted=full.rmse,
        rmse_reference=ref.rmse,
        decimated=int(decimation),
        outputs=list(model.outputs),
        fits={
            "time": rec.time,
            "measured": rec.y(model),
            "reference": same.y,
            "refitted": full.y,
        },
    )
