"""Simulation-error fitting of ODE models (nominal or with candidate effects).

:func:`fit_model` estimates the free parameters, the initial state and the parameters
of any attached effects by minimising the simulation error on a training part of a
recording. Internally many *jobs* (structures x starting points) are fitted at once by a
batched Levenberg-Marquardt: every iteration simulates, in one batched RK4 pass, each
job's trial point together with the finite-difference perturbations that give its
Jacobian. Positive parameters are optimised in log space; all have bounds.
"""

from __future__ import annotations

import contextvars
import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit._checks import uniform_step
from pdmkit.errors import DataError, ModelError
from pdmkit.models._xp import NumpyNamespace
from pdmkit.models.mismatch._candidates import Effect, Scales
from pdmkit.models.ode import integrate_batch, stable_substeps, state_jacobians

_NP = NumpyNamespace()

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
    >>> from pdmkit.models.mismatch._fit import make_recording
    >>> from pdmkit.models.ode import showcase_model
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
    #: the time from which a drift counts (None: the first sample; a part of a longer
    #: record keeps the record's start)
    t_origin: float | None = None

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
    >>> from pdmkit.models.mismatch._fit import make_recording
    >>> from pdmkit.models.ode import showcase_model
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


def data_states(model, rec: Recording, samples: np.ndarray, fallback) -> np.ndarray:
    """States at ``samples`` guessed from the data, ``(len(samples), nx)``.

    A measured output is its own state; a velocity is the slope of its measured
    position (over four samples); any other state takes ``fallback`` (``(nx,)``).
    """
    k = np.asarray(samples, dtype=int)
    X = np.tile(np.asarray(fallback, dtype=float), (k.size, 1))
    position = [
        q
        for q, kq in model.states.items()
        if kq in ("position", "angle") and q in rec.outputs
    ]
    for j, (s, kind) in enumerate(model.states.items()):
        if s in rec.outputs:
            X[:, j] = rec.outputs[s][k]
        elif kind in ("velocity", "angular_velocity") and len(position) == 1:
            y = rec.outputs[position[0]]
            lo, hi = np.maximum(k - 2, 0), np.minimum(k + 2, rec.n - 1)
            X[:, j] = (y[hi] - y[lo]) / ((hi - lo) * rec.ts)
    lo = np.array([0.0 if kd == "level" else -np.inf for kd in model.states.values()])
    return np.maximum(X, lo[None, :])


# ---------------------------------------------------------------------------- layout
@dataclasses.dataclass
class _Layout:
    """Which values a job fits, in what space, within what bounds."""

    names: list[str]  # "p:<param>", "<effect key>.<param>"
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
    """One structure fitted from one start: state of its Levenberg-Marquardt run.

    ``theta`` holds the values the layout names (model and effect parameters, in the
    optimiser's space); ``x0`` the initial state of every fitted piece of the record,
    ``(K, n_states)`` (one row when the record is fitted whole), fitted alongside when
    ``fit_x0``.
    """

    effects: tuple[Effect, ...]
    layout: _Layout
    fixed: dict[str, float]  # every parameter value not in layout
    theta: np.ndarray
    sign: dict[str, float]  # sign of log-space values (negative nominal parameters)
    x0: np.ndarray  # (K, nx) initial state of each fitted piece
    x0_scale: np.ndarray  # (nx,) typical magnitude of each state (finite differences)
    x0_lo: np.ndarray  # (nx,) lower bound of each state (0 for levels)
    fit_x0: bool = True
    state_names: tuple[str, ...] = ()
    tag: str = ""
    cost: float = math.inf
    r: np.ndarray | None = None
    J: np.ndarray | None = None  # (m, n_theta) Jacobian of r in theta
    Jx: np.ndarray | None = None  # (K, m / K, nx) Jacobian of each piece in its x0
    lam: float = 1e-2
    small: int = 0
    done: bool = False
    n_iter: int = 0
    n_eval: int = 0

    def values(self, theta: np.ndarray | None = None) -> dict[str, float]:
        """Every parameter value and the first piece's initial state (``x0:``)."""
        th = self.theta if theta is None else theta
        vals = dict(self.fixed)
        dec = self.layout.decode(th)
        for k, v in dec.items():
            vals[k] = v * self.sign.get(k, 1.0)
        for j, name in enumerate(self.state_names):
            vals[f"x0:{name}"] = float(self.x0[0, j])
        return vals

    @property
    def n_fitted(self) -> int:
        """How many values the fit adjusts (parameters and initial states)."""
        return self.layout.n + (self.x0.size if self.fit_x0 else 0)


def _param_layout(
    model,
    effects: Sequence[Effect],
    scales: Scales | None,
    fit_free: bool,
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
class _NoEffects:
    """A row of :meth:`_Problem.simulate` for the model alone."""

    effects: tuple = ()


@dataclasses.dataclass
class _Problem:
    """What every job of one batch shares: model, recording, fitted span, weights.

    The fit covers samples ``[0, n_fit)``; long records are fitted in pieces
    (``starts``, ``length``: multiple shooting, each piece from its own fitted initial
    state), short ones whole (one piece from sample 0).
    """

    model: Any
    rec: Recording
    n_fit: int  # samples simulated (fit on [0, n_fit))
    weights: np.ndarray  # (n_out,) 1 / output scale
    n_sub: int
    starts: np.ndarray | None = None  # (K,) first sample of each fitted piece
    length: int | None = None  # samples per piece

    def __post_init__(self):
        if self.starts is None:
            self.starts, self.length = np.array([0]), self.n_fit
        self.starts = np.asarray(self.starts, dtype=int)
        idx = (self.starts[:, None] + np.arange(self.length)[None, :]).ravel()
        self._y = self.rec.y(self.model)[idx]  # (K * L, n_out) the data fitted

    @property
    def n_pieces(self) -> int:
        return int(self.starts.size)

    @property
    def n_res(self) -> int:
        """Number of fitted residuals (samples x outputs)."""
        return int(self._y.size)

    def sample_index(self) -> np.ndarray:
        """The recording's sample of every fitted residual row, ``(K * L,)``."""
        return (self.starts[:, None] + np.arange(self.length)[None, :]).ravel()

    def initial_pieces(self, x0_first: np.ndarray) -> np.ndarray:
        """A first guess of every piece's initial state, ``(K, nx)``, from the data.

        The first piece starts from ``x0_first``; the others from the measured
        outputs at their first sample, a velocity from the slope of its measured
        position, and any other state from ``x0_first``.
        """
        X = data_states(self.model, self.rec, self.starts, x0_first)
        X[0] = x0_first
        return X

    def states(self, values: Mapping[str, float], x0: np.ndarray) -> np.ndarray:
        """States along the fitted samples, ``(K * L, nx)``, pieces from ``x0``."""
        row = (_NoEffects(), values, np.asarray(x0, dtype=float))
        return self.simulate([row], states=True)[0]

    def with_step(self, n_sub: int) -> _Problem:
        """The same problem with another number of RK4 steps per sample."""
        return dataclasses.replace(self, n_sub=n_sub)

    def simulate(self, rows: Sequence[tuple], n: int | None = None, states: bool = False):
        """Outputs for rows of ``(job, values, x0)`` (the states with ``states``).

        Without ``n``: the fitted pieces, ``(B, K * L, n_out)``, ``x0`` of each row
        ``(K, nx)``. With ``n``: the first ``n`` samples simulated whole from the first
        piece's initial state ``x0[0]``, ``(B, n, n_out)``.
        """
        model = self.model
        B = len(rows)
        union: list[Effect] = []
        for job, *_ in rows:
            for e in job.effects:
                if e not in union:
                    union.append(e)
        theta = [
            {p: np.full(B, float(e.candidate.neutral[p])) for p in e.param_names}
            for e in union
        ]
        masks = [np.zeros(B, dtype=bool) for _ in union]
        P = {k: np.full(B, v) for k, v in model.params.items()}
        index = {e: i for i, e in enumerate(union)}
        for r, (job, vals, _x0) in enumerate(rows):
            for k in model.params:
                v = vals.get(f"p:{k}")
                if v is not None:
                    P[k][r] = v
            for e in job.effects:
                i = index[e]
                masks[i][r] = True
                for p in e.param_names:
                    theta[i][p][r] = vals[f"{e.key}.{p}"]
        # parameters identical in every row stay scalars (cheaper arithmetic)
        P = {k: (float(v[0]) if np.all(v == v[0]) else v) for k, v in P.items()}
        masks = [None if m.all() else m for m in masks]
        whole = n is not None or self.n_pieces == 1
        if whole:
            n = self.n_fit if n is None else n
            X0 = np.stack(
                [
                    np.asarray(x0, dtype=float).reshape(-1, x0.shape[-1])[0]
                    for *_, x0 in rows
                ]
            )
            segments = None
        else:
            n = int(self.starts[-1] + self.length)
            X0 = np.stack([np.asarray(x0, dtype=float) for *_, x0 in rows])
            segments = (self.starts, self.length)
        t = self.rec.time[:n]
        useq = {k: v[:n] for k, v in self.rec.inputs.items()}
        with np.errstate(all="ignore"):
            Y, X = integrate_batch(
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
                want_states=states,
                hold=self.rec.hold,
                segments=segments,
                t_origin=self.rec.t_origin,
            )
        return X if states else Y

    def residuals(self, Y: np.ndarray) -> np.ndarray:
        """Weighted residuals ``(B, K * L * n_out)`` (simulated minus measured)."""
        R = (Y - self._y[None]) * self.weights[None, None, :]
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


def _fd_rows(job: _Job, theta: np.ndarray, x0: np.ndarray):
    """Rows for ``r`` at ``(theta, x0)`` and its finite-difference Jacobian.

    One row per parameter; one row per *state* for the initial states of all pieces at
    once (each piece's residual depends on its own initial state only, so perturbing
    that state in every piece together gives every piece's column in one
    simulation). Returns ``(rows, theta steps, x0 steps (K, nx) or None)``.
    """
    steps = _fd_steps(job, theta)
    rows = [(job, job.values(theta), x0)]
    for i in range(job.layout.n):
        th2 = theta.copy()
        th2[i] += steps[i]
        rows.append((job, job.values(th2), x0))
    dx = None
    if job.fit_x0:
        dx = 1e-6 * np.maximum(np.abs(x0), job.x0_scale[None, :])
        vals = job.values(theta)
        for j in range(x0.shape[1]):
            x2 = x0.copy()
            x2[:, j] += dx[:, j]
            rows.append((job, vals, x2))
    return rows, steps, dx


def _fd_jacobians(R: np.ndarray, r0: int, job: _Job, steps, dx):
    """``(r, J, Jx)`` from the residual rows of :func:`_fd_rows` starting at ``r0``."""
    n = job.layout.n
    r = R[r0]
    J = (R[r0 + 1 : r0 + 1 + n] - r[None]).T / steps[None]
    J = np.where(np.isfinite(J), J, 0.0)
    Jx = None
    if dx is not None:
        K, nx = dx.shape
        D = R[r0 + 1 + n : r0 + 1 + n + nx] - r[None]  # (nx, m)
        D = D.reshape(nx, K, -1).transpose(1, 2, 0)  # (K, m / K, nx)
        Jx = D / dx[:, None, :]
        Jx = np.where(np.isfinite(Jx), Jx, 0.0)
    return r, J, Jx


def _lm_step(job: _Job, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """Damped Gauss-Newton step ``(d theta, d x0)`` for the job's ``r``, ``J``, ``Jx``.

    The initial states of the pieces enter block-diagonally: each piece's states are
    eliminated first (Schur complement), so a record cut into hundreds of pieces costs
    a few small solves, not one large one.
    """
    r, J = job.r, job.J
    n = J.shape[1]
    g = J.T @ r
    A = J.T @ J
    if job.Jx is None:
        D = np.clip(np.diag(A), 1e-12 * max(np.max(np.diag(A), initial=0.0), 1e-300), None)
        return _solve(A + lam * np.diag(D), -g), np.zeros_like(job.x0)
    K, mk, nx = job.Jx.shape
    Jx, rk = job.Jx, r.reshape(K, mk)
    Jk = J.reshape(K, mk, n)
    Axx = np.einsum("kmi,kmj->kij", Jx, Jx)  # (K, nx, nx)
    Agx = np.einsum("kmi,kmj->kij", Jk, Jx)  # (K, n, nx)
    gx = np.einsum("kmi,km->ki", Jx, rk)  # (K, nx)
    dA = np.diag(A) if n else np.zeros(0)
    dX = np.einsum("kii->ki", Axx)
    top = max(np.max(dA, initial=0.0), np.max(dX, initial=0.0), 1e-300)
    Axx = Axx + lam * np.einsum("ki,ij->kij", np.clip(dX, 1e-12 * top, None), np.eye(nx))
    Ainv = np.linalg.pinv(Axx)  # (K, nx, nx), batched
    if n:
        S = A + lam * np.diag(np.clip(dA, 1e-12 * top, None))
        S = S - np.einsum("kij,kjl,kml->im", Agx, Ainv, Agx)
        rhs = -g + np.einsum("kij,kjl,kl->i", Agx, Ainv, gx)
        dth = _solve(S, rhs)
    else:
        dth = np.zeros(0)
    dx = -np.einsum("kij,kj->ki", Ainv, gx + np.einsum("kji,j->ki", Agx, dth))
    return dth, dx


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, b, rcond=None)[0]


#: ``time.perf_counter()`` after which budgeted fits stop where they are (a discovery's
#: ``max_seconds``); each job keeps its best point so far
DEADLINE: contextvars.ContextVar[float] = contextvars.ContextVar(
    "deadline", default=math.inf
)


def _lm(  # noqa: C901, PLR0915
    problem: _Problem,
    jobs: Sequence[_Job],
    max_iter: int,
    ftol: float = 1e-5,
    budgeted: bool = True,
) -> None:
    """Batched Levenberg-Marquardt: update ``jobs`` in place, up to ``max_iter`` iterations.

    Fewer when ``budgeted`` and :data:`DEADLINE` has passed.
    """
    deadline = DEADLINE.get() if budgeted else math.inf
    for job in jobs:  # pieces' initial states start from the data when not given
        if job.x0.shape[0] != problem.n_pieces:
            job.x0 = problem.initial_pieces(job.x0[0])
            job.r = job.J = job.Jx = None
    for _ in range(max_iter + 1):
        active = [j for j in jobs if not j.done]
        if not active:
            return
        if time.perf_counter() > deadline and all(j.r is not None for j in active):
            return
        rows: list[tuple] = []
        plan = []  # (job, kind, payload, first row)
        for job in active:
            if job.J is None:
                if job.n_iter >= max_iter and job.r is not None:
                    continue
                frows, steps, dx = _fd_rows(job, job.theta, job.x0)
                plan.append((job, "jac", (steps, dx), len(rows)))
                rows += frows
            else:
                if job.n_iter >= max_iter:
                    continue
                trials = []
                for lam in (job.lam, 10.0 * job.lam):
                    dth, dx0 = _lm_step(job, lam)
                    th = np.clip(job.theta + dth, job.layout.lo, job.layout.hi)
                    x0 = np.maximum(job.x0 + dx0, job.x0_lo[None, :])
                    trials.append((th, x0))
                frows, steps, dx = _fd_rows(job, *trials[0])
                plan.append((job, "step", (trials, steps, dx), len(rows)))
                rows += frows
                rows.append((job, job.values(trials[1][0]), trials[1][1]))
        if not rows:
            return
        R = problem.residuals(problem.simulate(rows))
        for job, kind, payload, r0 in plan:
            job.n_eval += 1
            if kind == "jac":
                steps, dx = payload
                r, J, Jx = _fd_jacobians(R, r0, job, steps, dx)
                job.r, job.cost = r, _cost(r)
                if not math.isfinite(job.cost):
                    job.done = True
                    continue
                job.J, job.Jx = J, Jx
                continue
            trials, steps, dx = payload
            n_rows = 1 + job.layout.n + (job.x0.shape[1] if dx is not None else 0)
            job.n_iter += 1
            c1 = _cost(R[r0])
            c2 = _cost(R[r0 + n_rows])
            old = job.cost
            before = np.concatenate([job.theta, job.x0.ravel()])
            if c1 < old and c1 <= c2:
                (job.theta, job.x0), job.cost = trials[0], c1
                job.r, job.J, job.Jx = _fd_jacobians(R, r0, job, steps, dx)
                job.lam = max(job.lam / 3.0, 1e-9)
            elif c2 < old:
                (job.theta, job.x0), job.r, job.cost = trials[1], R[r0 + n_rows], c2
                job.J = job.Jx = None
                job.lam = job.lam * 2.0
            else:
                job.lam *= 10.0
                if job.lam > 1e10:
                    job.done = True
                continue
            after = np.concatenate([job.theta, job.x0.ravel()])
            rel = (old - job.cost) / max(old, 1e-300)
            tiny_step = np.linalg.norm(after - before) <= 1e-10 * (
                np.linalg.norm(after) + 1e-10
            )
            job.small = job.small + 1 if (rel < ftol or tiny_step) else 0
            if job.small >= 2 or job.cost < 1e-30:
                job.done = True


# ---------------------------------------------------------------------------- scales
def simulate_states(model, rec: Recording, values: Mapping[str, float], n_sub: int):
    """States ``(N, n_states)`` of ``model`` with ``values`` along ``rec``'s inputs.

    ``values`` holds ``p:`` parameters and ``x0:`` initial states; missing parameters are
    nominal.
    """
    P = {k: values.get(f"p:{k}", v) for k, v in model.params.items()}
    X0 = np.array([[values[f"x0:{s}"] for s in model.states]])
    with np.errstate(all="ignore"):
        _, Xt = integrate_batch(
            model, [], [], [], rec.time, rec.inputs, P, X0, n_sub, _NP, True, hold=rec.hold
        )
    return Xt[0]


def _nominal_scales(
    model,
    rec: Recording,
    values: Mapping[str, float],
    n_sub: int,
    along: tuple[np.ndarray, np.ndarray] | None = None,
) -> Scales:
    """Magnitudes of the trajectory simulated with ``values`` (for candidate guesses).

    ``along = (X, index)``: states already simulated at the recording's samples
    ``index`` (the fitted pieces of a long record), instead of a whole simulation.
    """
    t = rec.time
    P = {k: values.get(f"p:{k}", v) for k, v in model.params.items()}
    if along is None:
        X, index = simulate_states(model, rec, values, n_sub), np.arange(rec.n)
    else:
        X, index = along
    inputs = {k: v[index] for k, v in rec.inputs.items()}
    if not np.all(np.isfinite(X)):
        raise ModelError(
            f"{model.name}: the simulation with the fitted nominal parameters is not "
            "finite (it diverges); check the model, its parameters or INITIAL."
        )
    states = model.state_names
    xd = {s: X[:, j] for j, s in enumerate(states)}
    with np.errstate(all="ignore"):
        d = model.derivatives(xd, dict(inputs), P)
    F = {s: np.broadcast_to(np.asarray(d[s], dtype=float), (index.size,)) for s in states}
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
                d2 = model.derivatives(x2, dict(inputs), P)
            k = -(np.asarray(d2[v], dtype=float) - F[v]) / dx
            k = k[np.isfinite(k)] if np.ndim(k) else np.array([k])
            stiffness[(v, p)] = float(np.median(k)) if k.size else 0.0
    input_gain = {}
    for v, kv in kinds.items():
        if kv not in pos_of:
            continue
        for u in model.inputs:
            du = 1e-6 * max(float(np.std(inputs[u])), 1e-9)
            u2 = dict(inputs)
            u2[u] = inputs[u] + du
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


def _initial_values(model, rec: Recording) -> dict[str, float]:
    vals = {f"p:{k}": v for k, v in model.params.items()}
    for s in model.states:
        vals[f"x0:{s}"] = model.initial[s]
    for o in model.outputs:
        vals[f"x0:{o}"] = float(np.mean(rec.outputs[o][:3]))
    return vals


#: samples of a record's start simulated to choose the step and the pieces
_PREFIX = 4000


def _choose_n_sub(
    model,
    rec: Recording,
    values: Mapping[str, float],
    along: tuple[np.ndarray, np.ndarray] | None = None,
) -> int:
    """RK4 steps per sample for a stable simulation, from the model's fastest mode.

    The mode is taken along the record's first samples, or along given states
    ``(X, index)``.
    """
    P = {k: values.get(f"p:{k}", v) for k, v in model.params.items()}
    if along is None:
        head = part(rec, 0, _PREFIX)
        for n_sub in (1, 4, 16):
            X = simulate_states(model, head, values, n_sub)
            if np.all(np.isfinite(X)):
                break
        else:
            return 16
        index = np.arange(head.n)
    else:
        X, index = along
    with np.errstate(all="ignore"):
        need = stable_substeps(
            model, P, X, rec.ts, {k: v[index] for k, v in rec.inputs.items()}
        )
    return int(min(max(need, 1), 32))


def part(rec: Recording, start: int = 0, stop: int | None = None) -> Recording:
    """Samples ``start:stop`` of a recording (a drift still counts from its start)."""
    cut = slice(start, stop)
    return dataclasses.replace(
        rec,
        t_origin=float(rec.time[0]) if rec.t_origin is None else rec.t_origin,
        time=rec.time[cut],
        inputs={k: v[cut] for k, v in rec.inputs.items()},
        outputs={k: v[cut] for k, v in rec.outputs.items()},
    )


#: the step after decimation still resolves the model's fastest mode this many times
DECIMATE_SAMPLES_PER_TIME_CONSTANT = 20
#: ... and keeps at least this share of the inputs' variance below half its Nyquist
DECIMATE_KEEP_POWER = 0.99
#: largest decimation factor, and fewest samples left
DECIMATE_MAX, DECIMATE_MIN_SAMPLES = 10, 1000


def choose_decimation(
    model, rec: Recording, values: Mapping[str, float], n_sub: int
) -> int:
    """How many samples of an oversampled record to merge into one (1: none).

    A record sampled far faster than the model's fastest mode and its inputs need is
    decimated: the new step must resolve the fastest mode
    :data:`DECIMATE_SAMPLES_PER_TIME_CONSTANT` times, the inputs must keep
    :data:`DECIMATE_KEEP_POWER` of their variance below half the new Nyquist
    frequency, at most :data:`DECIMATE_MAX`, and :data:`DECIMATE_MIN_SAMPLES` samples
    must remain (see :func:`decimate`).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch._fit import choose_decimation, make_recording
    >>> msd = showcase_model("mass_spring_damper")  # resonance near 3 Hz
    >>> t = np.arange(40000) * 1e-4  # sampled at 10 kHz
    >>> F = 20 * np.sin(2 * np.pi * 0.5 * t)
    >>> rec = make_recording(msd, {"time": t, "F": F, "x": 0 * t})
    >>> values = {"p:" + k: v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    >>> choose_decimation(msd, rec, values, 1)
    10
    """
    head = part(rec, 0, min(rec.n, _PREFIX))
    X = simulate_states(model, head, values, n_sub)
    if not np.all(np.isfinite(X)):
        return 1
    P = {k: values.get(f"p:{k}", v) for k, v in model.params.items()}
    fast = [
        float(np.max(np.abs(np.linalg.eigvals(J))))
        for J in state_jacobians(model, P, X, head.inputs, 12)
    ]
    if not fast or max(fast) <= 0:
        return 1
    d = int(1.0 / (DECIMATE_SAMPLES_PER_TIME_CONSTANT * max(fast) * rec.ts))
    d = min(d, DECIMATE_MAX, rec.n // DECIMATE_MIN_SAMPLES)
    for u in rec.inputs.values():
        if d < 2:
            break
        spec = np.abs(np.fft.rfft(u - np.mean(u))) ** 2
        total = float(np.sum(spec[1:]))
        if total <= 0:
            continue
        cum = np.cumsum(spec[1:]) / total
        f = np.fft.rfftfreq(u.size, rec.ts)[1:]
        f_need = float(f[min(np.searchsorted(cum, DECIMATE_KEEP_POWER), f.size - 1)])
        # half the new Nyquist frequency must lie above f_need
        d = min(d, int(1.0 / (4.0 * f_need * rec.ts)) if f_need > 0 else d)
    return max(int(d), 1)


def decimate(rec: Recording, factor: int) -> Recording:
    """Every ``factor``-th sample.

    A held input (``rec.hold == "zoh"``) becomes the mean over the ``factor`` samples it
    stands for (held over that interval it delivers the same impulse); an interpolated one
    (``"foh"``, a smooth sampled signal) and each output are the samples themselves.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._fit import Recording, decimate
    >>> t = np.arange(6) * 0.1
    >>> rec = Recording(t, 0.1, {"u": np.arange(6.0)}, {"y": 10 * np.arange(6.0)})
    >>> r = decimate(rec, 3)
    >>> r.time.tolist(), r.inputs["u"].tolist(), r.outputs["y"].tolist()
    ([0.0, 0.30000000000000004], [1.0, 4.0], [0.0, 30.0])
    """
    n = (rec.n // factor) * factor
    if rec.hold == "zoh":
        blocks = {k: v[:n].reshape(-1, factor).mean(axis=1) for k, v in rec.inputs.items()}
    else:
        blocks = {k: v[:n:factor] for k, v in rec.inputs.items()}
    return dataclasses.replace(
        rec,
        time=rec.time[:n:factor],
        ts=rec.ts * factor,
        inputs=blocks,
        outputs={k: v[:n:factor] for k, v in rec.outputs.items()},
    )


#: records of up to this many fitted samples are simulated whole ...
PIECES_FROM = 3000
#: ... unless the model integrates (a pole at zero: a position driven by a force), whose
#: free-run error drifts without bound: from this many samples such a record is fitted
#: in pieces too, so that no drift runs longer than a piece (one long drift leaves the
#: fit with many local minima: open-loop friction fits on EMPS stopped in them)
PIECES_FROM_INTEGRATING = 1000
#: at most this many samples in the fitted pieces of a long record
PIECES_BUDGET = 16000
#: a piece lasts this many of the model's slowest time constants ...
PIECE_TIME_CONSTANTS = 5
#: ... and at least this many samples
PIECE_MIN = 400


def choose_pieces(
    model, rec: Recording, n_fit: int, values: Mapping[str, float], n_sub: int
) -> tuple[np.ndarray, int] | None:
    """Where a long record is cut into pieces for the fit (multiple shooting).

    Returns ``(starts, length)`` or ``None`` (fit the record whole): records of up to
    :data:`PIECES_FROM` samples (:data:`PIECES_FROM_INTEGRATING` for a model with an
    integrating mode, a zero eigenvalue of its state Jacobian), and models whose
    right-hand side reads the time, are fitted whole. A piece lasts
    :data:`PIECE_TIME_CONSTANTS` of the model's slowest decaying mode (at least
    :data:`PIECE_MIN` samples), so that its own initial state, fitted with it, has
    faded long before its end; at most
    :data:`PIECES_BUDGET` samples are fitted, in pieces spread evenly over the record.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch._fit import choose_pieces, make_recording
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(20000) * 0.01
    >>> rec = make_recording(msd, {"time": t, "F": np.sin(t), "x": 0 * t})
    >>> values = {"p:" + k: v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    >>> starts, length = choose_pieces(msd, rec, rec.n, values, 1)
    >>> int(starts[0]), len(starts) * length <= 16000
    (0, True)
    """
    if n_fit <= min(PIECES_FROM, PIECES_FROM_INTEGRATING):
        return None
    head = part(rec, 0, min(n_fit, _PREFIX))
    X = simulate_states(model, head, values, n_sub)
    if not np.all(np.isfinite(X)):
        return None
    P = {k: values.get(f"p:{k}", v) for k, v in model.params.items()}
    idx = np.unique(np.linspace(0, head.n - 1, 12).astype(int))
    x = {s: X[idx, j] for j, s in enumerate(model.states)}
    u = {k: v[idx] for k, v in head.inputs.items()}
    later = float(head.time[-1] - head.time[0]) * 3.7 + 11.3
    with np.errstate(all="ignore"):
        d0 = model.derivatives(x, u, P, t=float(head.time[0]))
        d1 = model.derivatives(x, u, P, t=float(head.time[0]) + later)
    for s in model.states:  # the model reads the clock: pieces would shift it
        a, b = np.asarray(d0[s], dtype=float), np.asarray(d1[s], dtype=float)
        if not np.allclose(a, b, rtol=1e-12, atol=0.0, equal_nan=True):
            return None
    rates, integrating = [], []
    for J in state_jacobians(model, P, X, {k: v for k, v in head.inputs.items()}, 12):
        lam = np.linalg.eigvals(J)
        fast = max(float(np.max(np.abs(lam))), 1e-300)
        decay = -lam.real[-lam.real > 1e-6 * fast]
        integrating.append(bool(np.any(np.abs(lam) <= 1e-9 * fast)))
        if decay.size:
            rates.append(float(np.min(decay)))
    if n_fit <= PIECES_FROM and not (integrating and all(integrating)):
        return None
    ts = rec.ts
    if rates:
        length = math.ceil(PIECE_TIME_CONSTANTS / float(np.median(rates)) / ts)
    else:  # no decaying mode: long pieces
        length = n_fit // 4
    length = int(min(max(length, PIECE_MIN), n_fit // 2))
    k_all = n_fit // length
    k = int(max(2, min(k_all, PIECES_BUDGET // length)))
    starts = np.round(np.linspace(0, n_fit - length, k)).astype(int)
    return starts, length


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
    x0=None,
):
    """Jobs for one structure, one per start.

    ``x0`` ``(K, nx)`` are the pieces' initial states (default: ``values``' ``x0:`` entries,
    spread over the pieces from the data when the fit starts).
    """
    states = list(model.states)
    if x0 is None:
        x0 = np.array([[values[f"x0:{s}"] for s in states]], dtype=float)
    x0_scale = np.array([max(x_scale.get(s, 1.0), 1e-9) for s in states])
    x0_lo = np.array([0.0 if k == "level" else -np.inf for k in model.states.values()])
    jobs = []
    for start in starts:
        vals = dict(values)
        for e in effects:
            for k, v in start.items():
                if k.startswith(e.key + "."):
                    vals[k] = v
        layout, sign = _param_layout(model, effects, scales, fit_free, vals, fit_effects)
        fixed = {k: v for k, v in vals.items() if k not in layout.names}
        enc = {k: vals[k] * sign.get(k, 1.0) for k in layout.names}
        jobs.append(
            _Job(
                tuple(effects),
                layout,
                fixed,
                layout.encode(enc),
                sign,
                x0=np.array(x0, dtype=float, copy=True),
                x0_scale=x0_scale,
                x0_lo=x0_lo,
                fit_x0=fit_x0,
                state_names=tuple(states),
                tag=tag,
            )
        )
    return jobs


def _effect_starts(effects: Sequence[Effect], scales: Scales) -> list[dict[str, float]]:
    """Cartesian product of every effect's guesses (qualified names)."""
    starts: list[dict[str, float]] = [{}]
    for e in effects:
        guesses = list(e.candidate.guesses(e, scales))
        neutral = {p: float(e.candidate.neutral[p]) for p in e.param_names}
        if e.candidate.start_neutral and neutral not in guesses:
            guesses.append(neutral)
        new = []
        for s in starts:
            for gss in guesses:
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


def nominal_scales(model, data: Recording | Any, fit: FitResult, n_sub: int) -> Scales:
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
