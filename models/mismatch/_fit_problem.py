"""The batched fitting problem of mismatch discovery: jobs, their layout, simulation.

Many *jobs* (structures x starting points) are fitted at once: a :class:`_Job` holds
one structure's parameters in the optimiser's space (:class:`_Layout`: positive
parameters as logarithms, all within bounds) and the initial state of every fitted
piece of the record; a :class:`_Problem` simulates rows of many jobs in one batched RK4
pass and hands trial points, each with the forward-difference perturbations that give
its Jacobian (:func:`_fd_rows`), to the shared batched Levenberg-Marquardt of
:mod:`pdmkit.models._optim` (:func:`_lm`).
"""

from __future__ import annotations

import contextvars
import dataclasses
import math
from collections.abc import Collection, Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit.models._optim import Evaluation, LMOptions, Trial, levenberg_marquardt
from pdmkit.models._xp import NumpyNamespace
from pdmkit.models.mismatch._candidates import Effect, Scales
from pdmkit.models.mismatch._recording import Recording, data_states
from pdmkit.models.ode import integrate_batch, runs_compiled

_NP = NumpyNamespace()


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
    history: list = dataclasses.field(default_factory=list)  # cost after each step
    fd_rel: np.ndarray | None = None  # (n_theta,) relative finite-difference steps

    def values(self, theta: np.ndarray | None = None) -> dict[str, float]:
        """Every parameter value and the first piece's initial state (``x0:``)."""
        th = self.theta if theta is None else theta
        vals = dict(self.fixed)
        dec = self.layout.decode(th)
        vals.update(dec)
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
    fit_free: bool | Collection[str],
    values: Mapping[str, float],
    fit_effects: bool = True,
):
    """The fitted parameters' names, log flags, bounds and scales.

    ``fit_free``: every free parameter (True), none (False) or those named.
    """
    names, log, lo, hi, sc = [], [], [], [], []
    if fit_free is True or fit_free is False:
        fitted = model.free if fit_free else []
    else:
        fitted = [p for p in model.free if p in fit_free]
    for p in fitted:
        v = values[f"p:{p}"]
        nominal = model.params[p]
        ref = abs(nominal) if nominal != 0 else max(abs(v), 1.0)
        names.append(f"p:{p}")
        # a positive parameter (a mass, a coefficient) is fitted as its logarithm,
        # within a factor 1e3 of the file's value; a negative one is a signed
        # quantity (an offset), free to cross zero
        if nominal > 0:
            log.append(True)
            lo.append(math.log(ref) - math.log(1e3))
            hi.append(math.log(ref) + math.log(1e3))
            sc.append(1.0)
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
    return layout


# ---------------------------------------------------------------------------- batch sim
@dataclasses.dataclass(frozen=True)
class _Row:
    """A row of :meth:`_Problem.simulate` that is no job: the model with ``effects``."""

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

    def initial_pieces(
        self, x0_first: np.ndarray, values: Mapping[str, float] | None = None
    ) -> np.ndarray:
        """A first guess of every piece's initial state, ``(K, nx)``, from the data.

        The first piece starts from ``x0_first``; the others from the measured
        outputs at their first sample and a velocity from the slope of its measured
        position. An unmeasured state (a chamber pressure) is carried over: with
        ``values``, it is the state a simulation from ``x0_first`` reaches at the
        piece's start (never the model file's initial value, which belongs to
        sample 0 only); without, ``x0_first``.
        """
        fallback = np.asarray(x0_first, dtype=float)
        if values is not None and self.n_pieces > 1:
            n = int(self.starts[-1]) + 1
            row = (_Row(), values, fallback[None, :])
            X = self.simulate([row], n=n, states=True)[0]
            if np.all(np.isfinite(X[self.starts])):
                fallback = X[self.starts]
        X = data_states(self.model, self.rec, self.starts, fallback)
        X[0] = x0_first
        return X

    def states(self, values: Mapping[str, float], x0: np.ndarray) -> np.ndarray:
        """States along the fitted samples, ``(K * L, nx)``, pieces from ``x0``."""
        row = (_Row(), values, np.asarray(x0, dtype=float))
        return self.simulate([row], states=True)[0]

    def with_step(self, n_sub: int) -> _Problem:
        """The same problem with another number of RK4 steps per sample."""
        return dataclasses.replace(self, n_sub=n_sub)

    def simulate(self, rows: Sequence[tuple], n: int | None = None, states: bool = False):
        """Outputs for rows of ``(job, values, x0)`` (the states with ``states``).

        Without ``n``: the fitted pieces, ``(B, K * L, n_out)``, ``x0`` of each row
        ``(K, nx)``. With ``n``: the first ``n`` samples simulated whole from the first
        piece's initial state ``x0[0]``, ``(B, n, n_out)``.

        With a compiled model (:mod:`pdmkit.models.ode._compiled`), rows whose effects
        the compiled loop takes are simulated apart from the others (a user's effect
        it cannot translate, a lag on a computed output), so they still run compiled.
        """
        model = self.model
        fast = [r for r, row in enumerate(rows) if runs_compiled(model, row[0].effects)]
        if len(fast) in (0, len(rows)):
            return self._simulate(rows, n, states)
        taken = set(fast)
        other = [r for r in range(len(rows)) if r not in taken]
        parts = [self._simulate([rows[r] for r in g], n, states) for g in (fast, other)]
        out = np.empty((len(rows), *parts[0].shape[1:]), dtype=parts[0].dtype)
        out[fast], out[other] = parts
        return out

    def _simulate(self, rows: Sequence[tuple], n: int | None, states: bool):
        """:meth:`simulate` of one batch."""
        model = self.model
        B = len(rows)
        union: list[Effect] = []
        for job, *_ in rows:
            for e in job.effects:
                if e not in union:
                    union.append(e)
        theta = [{p: np.full(B, float(e.neutral[p])) for p in e.param_names} for e in union]
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

    def bounds(self, job: _Job) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Bounds of a job's values (its layout's) and the lower bound of its states."""
        return job.layout.lo, job.layout.hi, job.x0_lo

    def evaluate(self, trials: Sequence[Trial]) -> list[Evaluation]:
        """Residuals of trial points of jobs, with the Jacobians asked for: one batch.

        A trial with a Jacobian adds its finite-difference rows (:func:`_fd_rows`).
        """
        rows: list[tuple] = []
        plan = []
        for t in trials:
            if t.jacobian:
                frows, steps, dx = _fd_rows(t.run, t.theta, t.x0)
                plan.append((len(rows), steps, dx))
                rows += frows
            else:
                plan.append((len(rows), None, None))
                rows.append((t.run, t.run.values(t.theta), t.x0))
        R = self.residuals(self.simulate(rows))
        out = []
        for t, (r0, steps, dx) in zip(trials, plan, strict=True):
            if steps is None:
                out.append(Evaluation(R[r0]))
            else:
                out.append(Evaluation(*_fd_jacobians(R, r0, t.run, steps, dx)))
        return out


#: relative finite-difference steps: the small one for smooth residuals, the large one
#: for a parameter whose residual is rough at the small scale (a switching law: an
#: end-stop damper, a valve opening, crosses an RK4 step as the parameter moves, and
#: a 1e-6 step then measures that jump, not the slope). A job's first Jacobian is
#: taken at both; a column whose two estimates differ by more than
#: ``FD_AGREEMENT`` of their size keeps the large step for the rest of the fit.
#: (On the pneumatic rig's model the small steps alone end the fit at b_up = 3.3 N s/m
#: and 7.2 mm validation RMSE; with the large ones for its dampers, at 1.1e4 and 2 mm.)
FD_SMALL, FD_LARGE, FD_AGREEMENT = 1e-6, 1e-2, 0.1


def _fd_steps(job: _Job, theta: np.ndarray, rel=None) -> np.ndarray:
    lay = job.layout
    rel = (FD_SMALL if job.fd_rel is None else job.fd_rel) if rel is None else rel
    d = rel * np.maximum(np.abs(theta), lay.scale)
    d = np.where(theta + d > lay.hi, -d, d)
    return d


def _fd_rows(job: _Job, theta: np.ndarray, x0: np.ndarray):
    """Rows for ``r`` at ``(theta, x0)`` and its finite-difference Jacobian.

    One row per parameter; one row per *state* for the initial states of all pieces at
    once (each piece's residual depends on its own initial state only, so perturbing
    that state in every piece together gives every piece's column in one
    simulation). A job's first Jacobian adds one row per parameter at the large step
    (:data:`FD_LARGE`). Returns ``(rows, theta steps, x0 steps (K, nx) or None)``;
    the steps are ``(2, n)`` when the large ones are included.
    """
    steps = _fd_steps(job, theta)
    if job.fd_rel is None:
        steps = np.stack([steps, _fd_steps(job, theta, FD_LARGE)])
    rows = [(job, job.values(theta), x0)]
    for step in np.atleast_2d(steps):
        for i in range(job.layout.n):
            th2 = theta.copy()
            th2[i] += step[i]
            rows.append((job, job.values(th2), x0))
    dx = None
    if job.fit_x0:
        dx = X0_FD_REL * np.maximum(np.abs(x0), job.x0_scale[None, :])
        vals = job.values(theta)
        for j in range(x0.shape[1]):
            x2 = x0.copy()
            x2[:, j] += dx[:, j]
            rows.append((job, vals, x2))
    return rows, steps, dx


def _fd_columns(R: np.ndarray, r0: int, job: _Job, steps: np.ndarray) -> np.ndarray:
    """The parameter Jacobian ``(m, n)``; from a first Jacobian, each column's step."""
    n = job.layout.n
    r = R[r0]
    with np.errstate(all="ignore"):
        if steps.ndim == 1:
            J = (R[r0 + 1 : r0 + 1 + n] - r[None]).T / steps[None]
            return np.where(np.isfinite(J), J, 0.0)
        small = (R[r0 + 1 : r0 + 1 + n] - r[None]).T / steps[0][None]
        large = (R[r0 + 1 + n : r0 + 1 + 2 * n] - r[None]).T / steps[1][None]
        small = np.where(np.isfinite(small), small, 0.0)
        large = np.where(np.isfinite(large), large, 0.0)
        differ = np.linalg.norm(small - large, axis=0)
        size = np.maximum(np.linalg.norm(small, axis=0), np.linalg.norm(large, axis=0))
    rough = differ > FD_AGREEMENT * size
    job.fd_rel = np.where(rough, FD_LARGE, FD_SMALL)
    return np.where(rough[None, :], large, small)


def _fd_jacobians(R: np.ndarray, r0: int, job: _Job, steps, dx):
    """``(r, J, Jx)`` from the residual rows of :func:`_fd_rows` starting at ``r0``."""
    n_rows = job.layout.n * (1 if steps.ndim == 1 else steps.shape[0])
    r = R[r0]
    J = _fd_columns(R, r0, job, steps)
    Jx = None
    if dx is not None:
        K, nx = dx.shape
        D = R[r0 + 1 + n_rows : r0 + 1 + n_rows + nx] - r[None]  # (nx, m)
        D = D.reshape(nx, K, -1).transpose(1, 2, 0)  # (K, m / K, nx)
        Jx = D / dx[:, None, :]
        Jx = np.where(np.isfinite(Jx), Jx, 0.0)
        Jx = _hold_negligible_states(Jx, r.reshape(K, -1), dx / X0_FD_REL)
    return r, J, Jx


#: relative finite-difference step of the initial states
X0_FD_REL = 1e-6
#: an initial state whose typical change moves a piece's residual by less than this
#: share of it is held (its Jacobian column zeroed)
X0_NEGLIGIBLE = 1e-3


def _hold_negligible_states(Jx: np.ndarray, r: np.ndarray, scale: np.ndarray):
    """``Jx`` with the columns of states that hardly move the residual zeroed.

    A state the data cannot see at a piece's start (a lever resting on its stop: its
    velocity; a chamber's pressure the valve resets at once) has a column near zero,
    and a Gauss-Newton step divides by it: LM then proposes an initial velocity of
    metres per second, every trial fails and the parameters never move. Such a state
    is held where its typical change (``scale``: its value or its measured scale)
    moves the piece's residual by less than :data:`X0_NEGLIGIBLE` of its norm.
    """
    with np.errstate(over="ignore", invalid="ignore"):  # an overflowing norm: inf
        effect = np.linalg.norm(Jx, axis=1) * scale  # (K, nx)
        size = np.linalg.norm(r, axis=1)[:, None]  # (K, 1)
        held = effect < X0_NEGLIGIBLE * size
    return np.where(held[:, None, :], 0.0, Jx)


#: ``time.perf_counter()`` after which budgeted fits stop where they are (a discovery's
#: ``max_seconds``); each job keeps its best point so far
DEADLINE: contextvars.ContextVar[float] = contextvars.ContextVar(
    "deadline", default=math.inf
)


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
        layout = _param_layout(model, effects, scales, fit_free, vals, fit_effects)
        fixed = {k: v for k, v in vals.items() if k not in layout.names}
        enc = {k: vals[k] for k in layout.names}
        jobs.append(
            _Job(
                tuple(effects),
                layout,
                fixed,
                layout.encode(enc),
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
        neutral = {p: float(e.neutral[p]) for p in e.param_names}
        if e.candidate.start_neutral and neutral not in guesses:
            guesses.append(neutral)
        new = []
        for s in starts:
            for gss in guesses:
                new.append({**s, **{f"{e.key}.{k}": v for k, v in gss.items()}})
        starts = new
    return starts


#: the damping schedule of the candidate fits: try lambda and 10 lambda (the first with
#: its Jacobian); lambda / 3 after the first was taken, 2 lambda after the second (whose
#: Jacobian comes in the next pass), 10 lambda when neither lowers the cost, given up
#: above 1e10; a job stops when the cost decreases by less than ``ftol`` (or the step is
#: below 1e-10 of the point) twice in a row, or the cost falls below 1e-30
def _lm_options(ftol: float) -> LMOptions:
    """The shared LM's options for mismatch fits stopping at relative decrease ``ftol``."""
    return LMOptions(
        trials=(1.0, 10.0),
        after_accept=((1.0, 3.0), (2.0, 1.0)),
        lam_min=1e-9,
        lam_max=math.inf,
        after_reject=10.0,
        give_up=1e10,
        trial_jacobians=1,
        refresh_now=False,
        ftol=ftol,
        xtol=1e-10,
        cost_floor=1e-30,
    )


def _lm(
    problem: _Problem,
    jobs: Sequence[_Job],
    max_iter: int,
    ftol: float = 1e-5,
    budgeted: bool = True,
) -> None:
    """Batched Levenberg-Marquardt: update ``jobs`` in place, up to ``max_iter`` iterations.

    Fewer when ``budgeted`` and :data:`DEADLINE` has passed. A job with one initial
    state for several pieces starts them from the data (:meth:`_Problem.initial_pieces`).
    """
    deadline = DEADLINE.get() if budgeted else math.inf
    for job in jobs:  # pieces' initial states start from the data when not given
        if job.x0.shape[0] != problem.n_pieces:
            job.x0 = problem.initial_pieces(job.x0[0], job.values())
            job.r = job.J = job.Jx = None
    levenberg_marquardt(problem, jobs, max_iter, _lm_options(ftol), deadline=deadline)
