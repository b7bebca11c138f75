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
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit._checks import uniform_step
from pdmkit.errors import DataError, ModelError
from pdmkit.models._candidates import Effect, Scales
from pdmkit.models._odesim import _NP, _run, _stable_n_sub

__all__ = ["FitResult", "Recording", "fit_model", "make_recording", "nominal_scales"]


# ---------------------------------------------------------------------------- data
@dataclasses.dataclass
class Recording:
    """A measured recording: uniform time, the model's inputs and outputs.

    Attributes
    ----------
    time : ndarray, shape (N,)
    ts : float
        Sample interval (s).
    inputs : dict of str to ndarray (N,)
    outputs : dict of str to ndarray (N,)
    name : str
        Where it came from (used in messages).

    Examples
    --------
    >>> import numpy as np
    >>> import pandas as pd
    >>> from pdmkit.models._mismatch_fit import make_recording
    >>> from pdmkit.models._mismatch_cases import showcase_model
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(20) * 0.1
    >>> rec = make_recording(msd, pd.DataFrame({"time": t, "F": 1 + 0 * t, "x": 0 * t}))
    >>> rec.ts, list(rec.outputs)
    (0.1, ['x'])
    """

    time: np.ndarray
    ts: float
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    name: str = "data"
    #: the inputs between samples: "zoh" (held) or "foh" (straight lines)
    hold: str = "zoh"

    @property
    def n(self) -> int:
        return self.time.size

    def y(self, model) -> np.ndarray:
        """Outputs as an ``(N, n_outputs)`` array in the model's output order."""
        return np.stack([self.outputs[o] for o in model.outputs], 1)


def make_recording(model, data: Any, name: str = "data") -> Recording:
    """Check a table against a model and return a :class:`Recording`.

    Parameters
    ----------
    model : OdeModel
    data : pandas.DataFrame or mapping of column name to 1-D array
        A ``time`` column (s, uniform, increasing), one column per model input and
        one per model output, all finite.
    name : str
        The data's name or file, used in error messages.

    Returns
    -------
    Recording

    Raises
    ------
    pdmkit.errors.DataError
        A column is missing or not numeric, a value is NaN or infinite (the message
        names the column and the row), or the time is not uniform and increasing.

    Examples
    --------
    >>> from pdmkit.models._mismatch_fit import make_recording
    >>> from pdmkit.models._mismatch_cases import showcase_model
    >>> import numpy as np
    >>> t = np.arange(12) * 0.1
    >>> t[5:] += 0.1
    >>> make_recording(showcase_model("mass_spring_damper"),
    ...                {"time": t, "F": 0 * t, "x": 0 * t}, name="run.csv")
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: run.csv: time must be uniform; row 5 (time 0.6) is 0.2 s ...
    """
    columns = list(data.keys()) if not hasattr(data, "columns") else list(data.columns)
    need = ["time", *model.input_names, *model.outputs]
    missing = [c for c in need if c not in columns]
    if missing:
        raise DataError(
            f"{name}: missing column(s) {missing}; the model needs a 'time' column, its "
            f"inputs {model.input_names} and its outputs {model.outputs}. Found columns: "
            f"{columns}."
        )
    arrays = {}
    for c in need:
        raw = np.asarray(data[c])
        try:
            v = raw.astype(np.float64)
        except (TypeError, ValueError):
            raise DataError(
                f"{name}: column {c!r} must be numeric; found values such as "
                f"{raw[:3].tolist()}."
            ) from None
        if v.ndim != 1:
            raise DataError(f"{name}: column {c!r} must be 1-D; got shape {v.shape}.")
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise DataError(
                f"{name}: column {c!r} has {bad.size} missing or non-finite value(s), "
                f"first at row {int(bad[0])} ({v[bad[0]]}); fill or drop those rows."
            )
        arrays[c] = v
    t = arrays["time"]
    if t.size < 10:
        raise DataError(f"{name}: needs at least 10 samples; got {t.size}.")
    ts = uniform_step(t, name)
    t = t[0] + ts * np.arange(t.size)
    return Recording(
        time=t,
        ts=ts,
        inputs={c: arrays[c] for c in model.input_names},
        outputs={c: arrays[c] for c in model.outputs},
        name=name,
    )


# ---------------------------------------------------------------------------- layout
@dataclasses.dataclass
class _Layout:
    """Which values a job fits, in what space, within what bounds."""

    names: list[str]  # "p:<param>", "x0:<state>", "<effect key>.<param>"
    log: np.ndarray
    lo: np.ndarray  # transformed bounds
    hi: np.ndarray
    scale: np.ndarray  # transformed typical magnitude (finite-difference steps)

    @property
    def n(self) -> int:
        return len(self.names)

    def encode(self, values: Mapping[str, float]) -> np.ndarray:
        v = np.array([values[k] for k in self.names], dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            th = np.where(self.log, np.log(np.abs(v)), v)
        return np.clip(th, self.lo, self.hi)

    def decode(self, theta: np.ndarray) -> dict[str, float]:
        v = np.where(self.log, np.exp(np.clip(theta, -700, 700)), theta)
        return {k: float(x) for k, x in zip(self.names, v, strict=True)}


@dataclasses.dataclass
class _Job:
    """One structure fitted from one start: state of its Levenberg-Marquardt run."""

    effects: tuple[Effect, ...]
    layout: _Layout
    fixed: dict[str, float]  # every value ("p:", "x0:", effect params) not in layout
    theta: np.ndarray
    sign: dict[str, float]  # sign of log-space values (negative nominal parameters)
    tag: str = ""
    cost: float = math.inf
    r: np.ndarray | None = None
    J: np.ndarray | None = None
    lam: float = 1e-2
    small: int = 0
    done: bool = False
    n_iter: int = 0
    n_eval: int = 0

    def values(self, theta: np.ndarray | None = None) -> dict[str, float]:
        th = self.theta if theta is None else theta
        vals = dict(self.fixed)
        dec = self.layout.decode(th)
        for k, v in dec.items():
            vals[k] = v * self.sign.get(k, 1.0)
        return vals


def _param_layout(
    model,
    effects: Sequence[Effect],
    scales: Scales | None,
    fit_free: bool,
    fit_x0: bool,
    x_scale: Mapping[str, float],
    values: Mapping[str, float],
    fit_effects: bool = True,
):
    names, log, lo, hi, sc, sign = [], [], [], [], [], {}
    if fit_free:
        for p in model.free:
            v = values[f"p:{p}"]
            nominal = model.params[p]
            ref = abs(nominal) if nominal != 0 else max(abs(v), 1.0)
            names.append(f"p:{p}")
            if nominal != 0:
                log.append(True)
                lo.append(math.log(ref) - math.log(1e3))
                hi.append(math.log(ref) + math.log(1e3))
                sc.append(1.0)
                sign[f"p:{p}"] = math.copysign(1.0, nominal)
            else:
                log.append(False)
                lo.append(-math.inf)
                hi.append(math.inf)
                sc.append(ref)
    if fit_x0:
        for s, kind in model.states.items():
            names.append(f"x0:{s}")
            log.append(False)
            lo.append(0.0 if kind == "level" else -math.inf)
            hi.append(math.inf)
            sc.append(max(x_scale.get(s, 1.0), 1e-9))
    for e in effects if fit_effects else ():
        specs = e.candidate.specs(e, scales)
        for p in e.param_names:
            spec = specs[p]
            names.append(f"{e.key}.{p}")
            log.append(spec.log)
            if spec.log:
                lo.append(math.log(max(spec.lower, 1e-300)))
                hi.append(math.log(spec.upper))
                sc.append(1.0)
            else:
                lo.append(spec.lower)
                hi.append(spec.upper)
                sc.append(spec.scale)
    layout = _Layout(
        names,
        np.array(log, dtype=bool),
        np.array(lo, dtype=float),
        np.array(hi, dtype=float),
        np.array(sc, dtype=float),
    )
    return layout, sign


# ---------------------------------------------------------------------------- batch sim
@dataclasses.dataclass
class _Problem:
    """What every job of one batch shares: model, recording, fitted span, weights."""

    model: Any
    rec: Recording
    n_fit: int  # samples simulated (fit on [0, n_fit))
    weights: np.ndarray  # (n_out,) 1 / output scale
    n_sub: int

    def simulate(
        self, rows: Sequence[tuple[_Job, Mapping[str, float]]], n: int | None = None
    ):
        """Outputs ``(B, n, n_out)`` for rows of (job, values)."""
        model = self.model
        n = self.n_fit if n is None else n
        B = len(rows)
        union: list[Effect] = []
        for job, _ in rows:
            for e in job.effects:
                if e not in union:
                    union.append(e)
        theta = [
            {p: np.full(B, float(e.candidate.neutral[p])) for p in e.param_names}
            for e in union
        ]
        masks = [np.zeros(B, dtype=bool) for _ in union]
        P = {k: np.full(B, v) for k, v in model.params.items()}
        X0 = np.empty((B, len(model.states)))
        index = {e: i for i, e in enumerate(union)}
        for r, (job, vals) in enumerate(rows):
            for k in model.params:
                v = vals.get(f"p:{k}")
                if v is not None:
                    P[k][r] = v
            for j, s in enumerate(model.states):
                X0[r, j] = vals[f"x0:{s}"]
            for e in job.effects:
                i = index[e]
                masks[i][r] = True
                for p in e.param_names:
                    theta[i][p][r] = vals[f"{e.key}.{p}"]
        # parameters identical in every row stay scalars (cheaper arithmetic)
        P = {k: (float(v[0]) if np.all(v == v[0]) else v) for k, v in P.items()}
        masks = [None if m.all() else m for m in masks]
        t = self.rec.time[:n]
        useq = {k: v[:n] for k, v in self.rec.inputs.items()}
        with np.errstate(all="ignore"):
            Y, _ = _run(
                model,
                union,
                theta,
                masks,
                t,
                useq,
                P,
                X0,
                self.n_sub,
                _NP,
                hold=self.rec.hold,
            )
        return Y

    def residuals(self, Y: np.ndarray) -> np.ndarray:
        """Weighted residuals ``(B, n_fit * n_out)`` (simulated minus measured)."""
        y = self.rec.y(self.model)[: self.n_fit]
        R = (Y - y[None]) * self.weights[None, None, :]
        R = R.reshape(R.shape[0], -1)
        return np.where(np.isfinite(R), R, np.nan)


def _cost(r: np.ndarray) -> float:
    with np.errstate(over="ignore"):  # a diverged trial step: its cost is inf
        c = 0.5 * float(np.dot(r, r))
    return c if math.isfinite(c) else math.inf


def _fd_steps(job: _Job, theta: np.ndarray) -> np.ndarray:
    lay = job.layout
    d = 1e-6 * np.maximum(np.abs(theta), lay.scale)
    d = np.where(theta + d > lay.hi, -d, d)
    return d


def _lm(problem: _Problem, jobs: Sequence[_Job], max_iter: int, ftol: float = 1e-5) -> None:
    """Batched Levenberg-Marquardt: update ``jobs`` in place for up to ``max_iter``."""
    for _ in range(max_iter + 1):
        active = [j for j in jobs if not j.done]
        if not active:
            return
        rows: list[tuple[_Job, Mapping[str, float]]] = []
        plan = []  # (job, kind, payload, first row)
        for job in active:
            if job.J is None:
                if job.n_iter >= max_iter and job.r is not None:
                    continue
                th = job.theta
                steps = _fd_steps(job, th)
                plan.append((job, "jac", (th, steps), len(rows)))
                rows.append((job, job.values(th)))
                for i in range(job.layout.n):
                    th2 = th.copy()
                    th2[i] += steps[i]
                    rows.append((job, job.values(th2)))
            else:
                if job.n_iter >= max_iter:
                    continue
                trials = []
                g = job.J.T @ job.r
                A = job.J.T @ job.J
                D = np.clip(np.diag(A), 1e-12 * max(np.max(np.diag(A)), 1e-300), None)
                for lam in (job.lam, 10.0 * job.lam):
                    try:
                        delta = np.linalg.solve(A + lam * np.diag(D), -g)
                    except np.linalg.LinAlgError:
                        delta = np.linalg.lstsq(A + lam * np.diag(D), -g, rcond=None)[0]
                    trials.append(np.clip(job.theta + delta, job.layout.lo, job.layout.hi))
                steps = _fd_steps(job, trials[0])
                plan.append((job, "step", (trials, steps), len(rows)))
                rows.append((job, job.values(trials[0])))
                for i in range(job.layout.n):
                    th2 = trials[0].copy()
                    th2[i] += steps[i]
                    rows.append((job, job.values(th2)))
                rows.append((job, job.values(trials[1])))
        if not rows:
            return
        R = problem.residuals(problem.simulate(rows))
        for job, kind, payload, r0 in plan:
            n = job.layout.n
            job.n_eval += 1
            if kind == "jac":
                th, steps = payload
                job.r = R[r0]
                job.cost = _cost(job.r)
                if not math.isfinite(job.cost):
                    job.done = True
                    continue
                J = (R[r0 + 1 : r0 + 1 + n] - job.r[None]).T / steps[None]
                job.J = np.where(np.isfinite(J), J, 0.0)
                continue
            trials, steps = payload
            job.n_iter += 1
            c1 = _cost(R[r0])
            c2 = _cost(R[r0 + n + 1])
            old = job.cost
            if c1 < old and c1 <= c2:
                step = trials[0] - job.theta
                job.theta, job.r, job.cost = trials[0], R[r0], c1
                J = (R[r0 + 1 : r0 + 1 + n] - job.r[None]).T / steps[None]
                job.J = np.where(np.isfinite(J), J, 0.0)
                job.lam = max(job.lam / 3.0, 1e-9)
            elif c2 < old:
                step = trials[1] - job.theta
                job.theta, job.r, job.cost = trials[1], R[r0 + n + 1], c2
                job.J = None
                job.lam = job.lam * 2.0
            else:
                job.lam *= 10.0
                if job.lam > 1e10:
                    job.done = True
                continue
            rel = (old - job.cost) / max(old, 1e-300)
            tiny_step = np.linalg.norm(step) <= 1e-10 * (np.linalg.norm(job.theta) + 1e-10)
            job.small = job.small + 1 if (rel < ftol or tiny_step) else 0
            if job.small >= 2 or job.cost < 1e-30:
                job.done = True


# ---------------------------------------------------------------------------- scales
def simulate_states(model, rec: Recording, values: Mapping[str, float], n_sub: int):
    """States ``(N, n_states)`` of ``model`` with ``values`` (``p:`` parameters,
    ``x0:`` initial states; missing parameters nominal) along ``rec``'s inputs."""
    P = {k: values.get(f"p:{k}", v) for k, v in model.params.items()}
    X0 = np.array([[values[f"x0:{s}"] for s in model.states]])
    with np.errstate(all="ignore"):
        _, Xt = _run(
            model, [], [], [], rec.time, rec.inputs, P, X0, n_sub, _NP, True, hold=rec.hold
        )
    return Xt[0]


def _nominal_scales(
    model, rec: Recording, values: Mapping[str, float], n_sub: int
) -> Scales:
    """Magnitudes of the trajectory simulated with ``values`` (for candidate guesses)."""
    t = rec.time
    P = {k: values.get(f"p:{k}", v) for k, v in model.params.items()}
    X = simulate_states(model, rec, values, n_sub)
    if not np.all(np.isfinite(X)):
        raise ModelError(
            f"{model.name}: the simulation with the fitted nominal parameters is not "
            "finite (it diverges); check the model, its parameters or INITIAL."
        )
    states = model.state_names
    xd = {s: X[:, j] for j, s in enumerate(states)}
    with np.errstate(all="ignore"):
        d = model.derivatives(xd, dict(rec.inputs), P)
    F = {s: np.broadcast_to(np.asarray(d[s], dtype=float), (rec.n,)) for s in states}
    stiffness = {}
    kinds = model.states
    pos_of = {"velocity": "position", "angular_velocity": "angle"}
    for v, kv in kinds.items():
        if kv not in pos_of:
            continue
        for p, kp in kinds.items():
            if kp != pos_of[kv]:
                continue
            dx = 1e-6 * max(float(np.std(xd[p])), 1e-9)
            x2 = dict(xd)
            x2[p] = xd[p] + dx
            with np.errstate(all="ignore"):
                d2 = model.derivatives(x2, dict(rec.inputs), P)
            k = -(np.asarray(d2[v], dtype=float) - F[v]) / dx
            k = k[np.isfinite(k)] if np.ndim(k) else np.array([k])
            stiffness[(v, p)] = float(np.median(k)) if k.size else 0.0
    input_gain = {}
    for v, kv in kinds.items():
        if kv not in pos_of:
            continue
        for u in model.inputs:
            du = 1e-6 * max(float(np.std(rec.inputs[u])), 1e-9)
            u2 = dict(rec.inputs)
            u2[u] = rec.inputs[u] + du
            with np.errstate(all="ignore"):
                d2 = model.derivatives(xd, u2, P)
            g = (np.asarray(d2[v], dtype=float) - F[v]) / du
            g = g[np.isfinite(g)] if np.ndim(g) else np.array([g])
            input_gain[(v, u)] = float(np.median(g)) if g.size else 0.0
    measured = {o: np.asarray(rec.outputs[o], dtype=float) for o in model.outputs}
    return Scales(
        y_min={o: float(np.nanmin(y)) for o, y in measured.items()},
        y_max={o: float(np.nanmax(y)) for o, y in measured.items()},
        input_gain=input_gain,
        ts=rec.ts,
        h=rec.ts / n_sub,
        duration=float(t[-1] - t[0] + rec.ts),
        x_min={s: float(np.min(xd[s])) for s in states},
        x_max={s: float(np.max(xd[s])) for s in states},
        x_std={s: float(np.std(xd[s])) for s in states},
        x_quantiles={s: np.quantile(xd[s], Scales.QUANTILES) for s in states},
        f_std={s: float(np.std(F[s])) for s in states},
        f_absmax={s: float(np.max(np.abs(F[s]))) for s in states},
        u_min={k: float(np.min(v)) for k, v in rec.inputs.items()},
        u_max={k: float(np.max(v)) for k, v in rec.inputs.items()},
        u_std={k: float(np.std(v)) for k, v in rec.inputs.items()},
        stiffness=stiffness,
    )


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
    >>> from pdmkit.models._mismatch_cases import showcase_model
    >>> from pdmkit.models._mismatch_fit import fit_model
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


def _initial_values(model, rec: Recording) -> dict[str, float]:
    vals = {f"p:{k}": v for k, v in model.params.items()}
    for s in model.states:
        vals[f"x0:{s}"] = model.initial[s]
    for o in model.outputs:
        vals[f"x0:{o}"] = float(np.mean(rec.outputs[o][:3]))
    return vals


def _choose_n_sub(model, rec: Recording, values: Mapping[str, float]) -> int:
    P = {k: values.get(f"p:{k}", v) for k, v in model.params.items()}
    for n_sub in (1, 4, 16):
        Xt = simulate_states(model, rec, values, n_sub)[None]
        if np.all(np.isfinite(Xt)):
            break
    else:
        return 16
    with np.errstate(all="ignore"):
        need = _stable_n_sub(model, P, Xt[0], rec.ts, rec.inputs)
    return int(min(max(need, 1), 32))


def _make_jobs(
    model,
    effects,
    scales,
    starts,
    values,
    x_scale,
    fit_free=True,
    fit_x0=True,
    tag="",
    fit_effects=True,
):
    jobs = []
    for start in starts:
        vals = dict(values)
        for e in effects:
            for k, v in start.items():
                if k.startswith(e.key + "."):
                    vals[k] = v
        layout, sign = _param_layout(
            model, effects, scales, fit_free, fit_x0, x_scale, vals, fit_effects
        )
        fixed = {k: v for k, v in vals.items() if k not in layout.names}
        enc = {k: vals[k] * sign.get(k, 1.0) for k in layout.names}
        jobs.append(_Job(tuple(effects), layout, fixed, layout.encode(enc), sign, tag=tag))
    return jobs


def _effect_starts(effects: Sequence[Effect], scales: Scales) -> list[dict[str, float]]:
    """Cartesian product of every effect's guesses (qualified names)."""
    starts: list[dict[str, float]] = [{}]
    for e in effects:
        new = []
        for s in starts:
            for gss in e.candidate.guesses(e, scales):
                new.append({**s, **{f"{e.key}.{k}": v for k, v in gss.items()}})
        starts = new
    return starts


def fit_model(
    model,
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
    >>> from pdmkit.models._mismatch_cases import showcase_model
    >>> from pdmkit.models._odesim import simulate_ode
    >>> from pdmkit.models._mismatch_fit import fit_model
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
        for o in model.outputs:
            x_scale[o] = float(np.std(rec.outputs[o])) or 1.0
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
    Y = problem.simulate([(job, vals)], n=n)[0]
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
        n_params=job.layout.n,
        n_iter=job.n_iter,
        y_sim=Y,
        tag=job.tag,
    )


def nominal_scales(model, data: Recording | Any, fit: FitResult, n_sub: int) -> Scales:
    """Magnitudes of the fitted nominal trajectory, for candidate guesses and widths.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._mismatch_cases import showcase_model
    >>> from pdmkit.models._mismatch_fit import fit_model, nominal_scales
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(200) * 0.02
    >>> F = np.repeat(np.random.default_rng(1).normal(0, 40, 20), 10)
    >>> fit = fit_model(msd, {"time": t, "F": F, "x": 0 * t})
    >>> round(nominal_scales(msd, {"time": t, "F": F, "x": 0 * t}, fit, 1).ts, 6)
    0.02
    """
    rec = data if isinstance(data, Recording) else make_recording(model, data)
    return _nominal_scales(model, rec, fit.values, n_sub)
