"""One batched Levenberg-Marquardt for the simulation-error fits of :mod:`pdmkit.models`.

The piston twin's parameter estimation (:mod:`pdmkit.models.pneumatic`) and mismatch
discovery's candidate fits (:mod:`pdmkit.models.mismatch`) both minimise half the sum of
squared residuals of a simulation from many starting points at once, where one batched
simulation of many parameter vectors costs about as much as one. :func:`levenberg_marquardt`
runs all starts together: every pass collects, from each active start, the trial points
of its damped Gauss-Newton steps (Levenberg 1944, Marquardt 1963: ``(J^T J + lambda D)
delta = -J^T r`` with ``D`` the diagonal of ``J^T J``), asks the problem for their
residuals (and Jacobians where wanted) in *one* call, and moves each start to its best
trial when that lowers its cost.

A problem says how to simulate and differentiate (:class:`LMProblem`: ``evaluate`` a batch
of :class:`Trial` points, ``bounds`` of a start); :class:`LMOptions` the damping schedule
and the stop rules, which differ between the callers and are kept as they were tuned.
Parameters may be of two kinds: ``theta``, shared by all residuals and boxed by bounds, and
optional ``x0``, one block of parameters per piece of the residual vector (the initial
states of multiple shooting), held above a lower bound; a block enters the normal
equations block-diagonally and is eliminated first (Schur complement), so hundreds of
pieces cost a few small solves.

Also here: the Gauss-Newton step restricted to the determined directions and the
parameters not held at a bound (:func:`gauss_newton_step`), Bates and Watts' relative
offset (:func:`relative_offset`: how many standard errors the optimiser still expects to
move) and the covariance ``s^2 (J^T J)^-1`` with unidentifiable parameters marked
(:func:`covariance`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any, NamedTuple, Protocol

import numpy as np

__all__ = [
    "Evaluation",
    "FunctionProblem",
    "LMOptions",
    "LMProblem",
    "LMRun",
    "Trial",
    "covariance",
    "damped_step",
    "gauss_newton_step",
    "half_squares",
    "levenberg_marquardt",
    "relative_offset",
]

#: relative curvature (of ``J^T J`` scaled to unit diagonal) below which a direction
#: counts as unidentifiable
NULL_CURVATURE = 1e-12


class Trial(NamedTuple):
    """A point of one start to evaluate: ``theta``, ``x0`` (or None), Jacobian or not."""

    run: Any
    theta: np.ndarray
    x0: np.ndarray | None
    jacobian: bool


class Evaluation(NamedTuple):
    """Residuals ``r`` (m,) at a trial; ``J`` (m, n) and ``Jx`` (K, m / K, nx) or None."""

    r: np.ndarray
    J: np.ndarray | None = None
    Jx: np.ndarray | None = None


@dataclasses.dataclass
class LMRun:
    """One start of :func:`levenberg_marquardt`: where it is and how it goes.

    A run may be any object with these attributes (``offset`` only where the stop rule
    tests it); the optimiser updates them in place.

    Attributes
    ----------
    theta : ndarray, shape (n,)
        The parameters (in the optimiser's space, e.g. logarithms).
    x0 : ndarray, shape (K, nx), or None
        Parameters of each piece of the residuals (the initial states of multiple
        shooting).
    lam : float
        Damping.
    cost : float
        Half the sum of squared residuals at ``theta`` (inf before the first evaluation).
    r, J, Jx : ndarray or None
        Residuals, their Jacobian in ``theta`` and in ``x0`` (None: to evaluate).
    done : bool
        The run has stopped.
    n_iter, n_eval : int
        Iterations (steps tried) and passes that evaluated this run.
    small : int
        Iterations in a row that moved the cost or the point too little.
    offset : float
        Gauss-Newton step in standard errors, squared (:func:`relative_offset`).
    history : list of float
        The cost after each accepted step.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._optim import LMRun
    >>> LMRun(np.zeros(2)).cost
    inf
    """

    theta: np.ndarray
    x0: np.ndarray | None = None
    lam: float = 1e-3
    cost: float = math.inf
    r: np.ndarray | None = None
    J: np.ndarray | None = None
    Jx: np.ndarray | None = None
    done: bool = False
    n_iter: int = 0
    n_eval: int = 0
    small: int = 0
    offset: float = math.inf
    history: list = dataclasses.field(default_factory=list)


class LMProblem(Protocol):
    """What :func:`levenberg_marquardt` needs of a problem (runs: see :class:`LMRun`)."""

    def bounds(self, run) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Lower and upper bounds of ``run.theta``, lower bound of ``run.x0`` (nx,)."""

    def evaluate(self, trials: Sequence[Trial]) -> list[Evaluation]:
        """Residuals (with the Jacobians asked for) at every trial, in the given order."""


class FunctionProblem:
    """A problem from a residual function ``fun(theta) -> r`` (one trial at a time).

    ``jac(theta) -> J`` gives the Jacobian, else forward differences (step ``1e-7
    max(|theta_j|, 1)``, backwards at an upper bound); ``lo`` and ``hi`` bound ``theta``
    (default: none). For tests and small problems; the model fits batch their trials.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._optim import FunctionProblem, Trial
    >>> fp = FunctionProblem(lambda th: th**2 - 1.0)
    >>> ev = fp.evaluate([Trial(None, np.array([2.0]), None, True)])[0]
    >>> ev.r.tolist(), ev.J.round(5).tolist()
    ([3.0], [[4.0]])
    """

    def __init__(self, fun, jac=None, lo=None, hi=None):
        self.fun, self.jac, self.lo, self.hi = fun, jac, lo, hi

    def bounds(self, run) -> tuple[np.ndarray, np.ndarray, None]:
        """The bounds given (unbounded by default)."""
        n = run.theta.size
        lo = np.full(n, -np.inf) if self.lo is None else np.asarray(self.lo, float)
        hi = np.full(n, np.inf) if self.hi is None else np.asarray(self.hi, float)
        return lo, hi, None

    def evaluate(self, trials: Sequence[Trial]) -> list[Evaluation]:
        """Residuals and, where asked, the Jacobian of each trial."""
        out = []
        for trial in trials:
            r = np.asarray(self.fun(trial.theta), dtype=float)
            J = None
            if trial.jacobian:
                J = self._jacobian(trial.theta, r)
            out.append(Evaluation(np.where(np.isfinite(r), r, np.nan), J))
        return out

    def _jacobian(self, theta: np.ndarray, r: np.ndarray) -> np.ndarray:
        """The Jacobian given, or forward differences."""
        if self.jac is not None:
            return np.asarray(self.jac(theta), dtype=float)
        hi = np.full(theta.size, np.inf) if self.hi is None else np.asarray(self.hi)
        J = np.empty((r.size, theta.size))
        for j in range(theta.size):
            h = 1e-7 * max(abs(theta[j]), 1.0)
            h = -h if theta[j] + h > hi[j] else h
            th = theta.copy()
            th[j] += h
            J[:, j] = (np.asarray(self.fun(th), dtype=float) - r) / h
        return np.where(np.isfinite(J), J, 0.0)


@dataclasses.dataclass(frozen=True)
class LMOptions:
    """Damping schedule and stop rules of :func:`levenberg_marquardt`.

    Attributes
    ----------
    trials : tuple of float
        Each iteration tries the steps damped by ``lambda * f`` for each ``f``; the
        lowest cost wins (the earlier on a tie) if it is below the current one.
    after_accept : tuple of (float, float)
        Per trial, ``(multiply, divide)``: lambda becomes ``lambda * multiply / divide``
        after that trial was accepted (a ratio, so that ``lambda / 3`` stays exact),
        then is clipped to ``[lam_min, lam_max]``.
    after_reject : float
        Lambda is multiplied by this when no trial lowers the cost ...
    give_up : float
        ... and the run stops once lambda exceeds this.
    trial_jacobians : int
        How many of the trials (the first ones) are evaluated with their Jacobian. An
        accepted trial without one gets it at once (``refresh_now``) or in the next
        pass (which then evaluates no step of that run).
    ftol : float
        The run stops when the cost decreased by less than this (relative) twice in a
        row ...
    xtol : float or None
        ... or (counted likewise) when the step moved ``theta`` and ``x0`` by at most
        ``xtol (|x| + xtol)``.
    cost_floor : float
        The run stops when its cost falls below this.
    offset_tol : float or None
        The run stops, converged, when its Gauss-Newton step is shorter than
        ``sqrt(offset_tol)`` standard errors (:func:`relative_offset`, written to
        ``run.offset``).
    test_at_start : bool
        Apply the stop rules after a Jacobian-only evaluation too (the start may already
        be converged).
    hold_bounds : bool
        Coordinates of ``theta`` on a bound whose gradient points outwards take no step
        (the others are solved for without them), instead of a step clipped to the box.
        A clipped step can stall a little short of an optimum on a bound; the model fits
        keep the clipped step they were tuned with (False).

    Examples
    --------
    >>> from pdmkit.models._optim import LMOptions
    >>> LMOptions().trials
    (0.1, 1.0, 10.0)
    """

    trials: tuple[float, ...] = (0.1, 1.0, 10.0)
    after_accept: tuple[tuple[float, float], ...] = ((0.1, 1.0), (1.0, 1.0), (10.0, 1.0))
    lam_min: float = 1e-12
    lam_max: float = 1e12
    after_reject: float = 100.0
    give_up: float = 1e12
    trial_jacobians: int = 3
    refresh_now: bool = False
    ftol: float = 1e-12
    xtol: float | None = None
    cost_floor: float = 0.0
    offset_tol: float | None = None
    test_at_start: bool = False
    hold_bounds: bool = False


def half_squares(r: np.ndarray) -> float:
    """Half the sum of squares of ``r``; inf when that is not finite (a diverged trial).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._optim import half_squares
    >>> half_squares(np.array([3.0, 4.0])), half_squares(np.array([np.nan]))
    (12.5, inf)
    """
    with np.errstate(over="ignore"):
        c = 0.5 * float(np.dot(r, r))
    return c if math.isfinite(c) else math.inf


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``A^-1 b``, by least squares where ``A`` is singular."""
    try:
        return np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, b, rcond=None)[0]


class _NormalEquations:
    """``J^T J`` and ``J^T r`` of one run, for damped steps at several lambdas."""

    def __init__(
        self,
        J: np.ndarray,
        r: np.ndarray,
        Jx: np.ndarray | None = None,
        free: np.ndarray | None = None,
    ):
        with np.errstate(over="ignore", invalid="ignore"):  # overflow: see _step
            self._build(J, r, Jx, free)

    def _build(self, J, r, Jx, free) -> None:
        self.free, self.p = free, J.shape[1]
        if free is not None:  # held coordinates take no step
            J = J[:, free]
        self.n = J.shape[1]
        self.g = J.T @ r
        self.A = J.T @ J
        self.Jx = Jx
        if Jx is None:
            top = max(np.max(np.diag(self.A), initial=0.0), 1e-300)
            self.D = np.clip(np.diag(self.A), 1e-12 * top, None)
            return
        K, mk, _ = Jx.shape
        rk = r.reshape(K, mk)
        Jk = J.reshape(K, mk, self.n)
        self.Axx = np.einsum("kmi,kmj->kij", Jx, Jx)  # (K, nx, nx)
        self.Agx = np.einsum("kmi,kmj->kij", Jk, Jx)  # (K, n, nx)
        self.gx = np.einsum("kmi,km->ki", Jx, rk)  # (K, nx)
        self.dA = np.diag(self.A) if self.n else np.zeros(0)
        self.dX = np.einsum("kii->ki", self.Axx)
        self.top = max(np.max(self.dA, initial=0.0), np.max(self.dX, initial=0.0), 1e-300)

    def step(self, lam: float) -> tuple[np.ndarray, np.ndarray | None]:
        """The step ``(d theta, d x0)`` damped by ``lam`` (``d x0`` None without x0)."""
        dth, dx = self._step(lam)
        if self.free is None:
            return dth, dx
        full = np.zeros(self.p)
        full[self.free] = dth
        return full, dx

    def _step(self, lam: float) -> tuple[np.ndarray, np.ndarray | None]:
        """The step in the coordinates not held.

        NaN where the normal equations are not finite (a Jacobian so steep that its
        squares overflow, far out in a diverging trial): such a step is a trial that
        fails, and the damping grows, instead of a linear-algebra error.
        """
        if self.Jx is None:
            A = self.A + lam * np.diag(self.D)
            if not (np.all(np.isfinite(A)) and np.all(np.isfinite(self.g))):
                return np.full(self.n, np.nan), None
            return _solve(A, -self.g), None
        K, _, nx = self.Jx.shape
        eye = np.eye(nx)
        Axx = self.Axx + lam * np.einsum(
            "ki,ij->kij", np.clip(self.dX, 1e-12 * self.top, None), eye
        )
        parts = (Axx, self.Agx, self.gx, self.A, self.g)
        if not all(np.all(np.isfinite(a)) for a in parts):
            return np.full(self.n, np.nan), np.full((K, nx), np.nan)
        Ainv = np.linalg.pinv(Axx)  # (K, nx, nx), batched
        Agx, gx = self.Agx, self.gx
        if self.n:
            S = self.A + lam * np.diag(np.clip(self.dA, 1e-12 * self.top, None))
            S = S - np.einsum("kij,kjl,kml->im", Agx, Ainv, Agx)
            rhs = -self.g + np.einsum("kij,kjl,kl->i", Agx, Ainv, gx)
            dth = _solve(S, rhs)
        else:
            dth = np.zeros(0)
        dx = -np.einsum("kij,kj->ki", Ainv, gx + np.einsum("kji,j->ki", Agx, dth))
        return dth, dx


def damped_step(
    J: np.ndarray, r: np.ndarray, lam: float, Jx: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Levenberg-Marquardt step: ``(J^T J + lam D) delta = -J^T r``, D = diag(J^T J).

    Parameters
    ----------
    J : ndarray, shape (m, n)
        Jacobian of the residuals in ``theta``.
    r : ndarray, shape (m,)
        Residuals.
    lam : float
        Damping.
    Jx : ndarray, shape (K, m / K, nx), optional
        Jacobian of each of K pieces of ``r`` in its own block of parameters (the
        initial states of multiple shooting); the blocks are eliminated first.

    Returns
    -------
    d_theta : ndarray, shape (n,)
    d_x0 : ndarray, shape (K, nx), or None without ``Jx``

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._optim import damped_step
    >>> J, r = np.array([[1.0, 0.0], [0.0, 2.0]]), np.array([1.0, 2.0])
    >>> damped_step(J, r, 0.0)[0].tolist()
    [-1.0, -1.0]
    """
    return _NormalEquations(J, r, Jx).step(lam)


def gauss_newton_step(
    J: np.ndarray, r: np.ndarray, fixed: np.ndarray | None = None
) -> np.ndarray:
    """Gauss-Newton step restricted to the directions the data determine.

    ``J^T J`` is scaled to unit diagonal; directions whose curvature is below
    :data:`NULL_CURVATURE` of the largest (unidentifiable combinations) get no step, nor
    do the coordinates in ``fixed`` (held at a bound).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._optim import gauss_newton_step
    >>> J, r = np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([1.0, 1.0])
    >>> gauss_newton_step(J, r).round(12).tolist()  # only the determined sum moves
    [-0.5, -0.5]
    """
    p = J.shape[1]
    free = np.ones(p, dtype=bool) if fixed is None else ~np.asarray(fixed)
    delta = np.zeros(p)
    if not free.any():
        return delta
    Jf = J[:, free]
    A = Jf.T @ Jf
    g = Jf.T @ r
    d = np.sqrt(np.diag(A))
    d = np.where(d > 1e-300, d, 1.0)
    w, V = np.linalg.eigh(A / np.outer(d, d))
    keep = w > NULL_CURVATURE * max(float(w.max()), 1e-300)
    inv = (V[:, keep] / w[keep]) @ V[:, keep].T
    delta[free] = -(inv @ (g / d)) / d
    return delta


def relative_offset(
    J: np.ndarray,
    r: np.ndarray,
    cost: float,
    theta: np.ndarray | None = None,
    lo: np.ndarray | None = None,
    hi: np.ndarray | None = None,
) -> float:
    """Squared length of the Gauss-Newton step in units of the standard errors.

    ``delta^T J^T J delta / s^2`` with ``s^2 = 2 cost / (m - n)``: how far the optimiser
    still expects to move, measured against the statistical uncertainty (Bates and
    Watts' relative offset, 1981). With bounds, coordinates of ``theta`` on a bound that
    the step would push further out are held there.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._optim import half_squares, relative_offset
    >>> J = np.vstack([np.ones(4), np.arange(4.0)]).T
    >>> r = np.array([0.1, -0.1, -0.1, 0.1])  # orthogonal to J's columns: an optimum
    >>> relative_offset(J, r, half_squares(r)) < 1e-20
    True
    """
    fixed = None if lo is None else _held(J, r, theta, lo, hi)
    delta = gauss_newton_step(J, r, fixed)
    s2 = 2.0 * cost / max(r.size - J.shape[1], 1)
    Jd = J @ delta
    return float(Jd @ Jd) / max(s2, 1e-300)


def _held(J, r, theta, lo, hi) -> np.ndarray:
    """Coordinates on a bound (within 1e-9 relative) that the descent pushes outwards."""
    g = J.T @ r  # gradient of the cost; the step goes along -g
    tol = 1e-9 * np.maximum(1.0, np.abs(theta))
    return ((theta <= lo + tol) & (g > 0)) | ((theta >= hi - tol) & (g < 0))


def covariance(J: np.ndarray, cost: float) -> tuple[np.ndarray, float]:
    """Covariance ``s^2 (J^T J)^-1`` of the parameters at an optimum, and ``s^2``.

    ``s^2 = 2 cost / (m - n)``. A parameter with no curvature, or taking part in a
    direction of (numerically) zero curvature, is unidentifiable: its variance is inf
    and its covariances NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._optim import covariance
    >>> J = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 0.0]])  # the second never matters
    >>> cov, s2 = covariance(J, 1.0)
    >>> float(cov[0, 0]), float(cov[1, 1]), s2
    (1.0, inf, 2.0)
    """
    n, p = J.shape
    s2 = 2.0 * cost / max(n - p, 1)
    A = J.T @ J
    d = np.sqrt(np.diag(A))
    cov = np.full((p, p), np.nan)
    dead = d <= 1e-300
    live = ~dead
    if live.any():
        Al = A[np.ix_(live, live)] / np.outer(d[live], d[live])
        w, V = np.linalg.eigh(Al)
        null = w < NULL_CURVATURE * max(float(w.max()), 1e-300)
        inv = (V[:, ~null] / w[~null]) @ V[:, ~null].T
        sub = s2 * inv / np.outer(d[live], d[live])
        idx = np.flatnonzero(live)
        cov[np.ix_(idx, idx)] = sub
        if null.any():
            weak = np.zeros(live.sum(), dtype=bool)
            for k in np.flatnonzero(null):
                weak |= np.abs(V[:, k]) > 0.1
            dead[idx[weak]] = True
    for j in np.flatnonzero(dead):
        cov[j, :] = np.nan
        cov[:, j] = np.nan
        cov[j, j] = math.inf
    return cov, s2


# ---------------------------------------------------------------------------- the loop
def levenberg_marquardt(
    problem: LMProblem,
    runs: Sequence[Any],
    max_iter: int,
    options: LMOptions,
    *,
    deadline: float = math.inf,
    ticks: Callable[[Iterable[int]], Iterable[int]] | None = None,
) -> None:
    """Batched Levenberg-Marquardt: update ``runs`` in place.

    Every pass evaluates, in one call of ``problem.evaluate``, the trial steps of every
    active run (and the residuals and Jacobian of a run that has none yet); a run stops
    by the rules of ``options``, after ``max_iter`` iterations (steps tried), or when
    its damping exceeds ``options.give_up``. At most ``max_iter + 1`` passes.

    Parameters
    ----------
    problem : LMProblem
        Batched residuals and Jacobians, and each run's bounds.
    runs : sequence
        The starts (see :class:`LMRun` for their attributes); a run with ``done``
        set is left alone, one without ``r`` is evaluated first.
    max_iter : int
        Iterations per run (counted over calls: a run that already made them is only
        evaluated where it has no residuals yet).
    options : LMOptions
        Damping schedule and stop rules.
    deadline : float
        ``time.perf_counter()`` after which the passes stop (once every run has its
        residuals); each run keeps its best point so far.
    ticks : callable, optional
        Wraps the passes (a progress bar).

    Examples
    --------
    Fit ``y = a exp(b t)`` from two starts at once:

    >>> import numpy as np
    >>> from pdmkit.models._optim import (FunctionProblem, LMOptions, LMRun,
    ...                                   levenberg_marquardt)
    >>> t = np.linspace(0, 1, 20)
    >>> fit = FunctionProblem(lambda th: th[0] * np.exp(th[1] * t) - 2 * np.exp(-t))
    >>> runs = [LMRun(np.array([1.0, 0.0])), LMRun(np.array([5.0, -3.0]))]
    >>> levenberg_marquardt(fit, runs, 50, LMOptions(ftol=1e-10))
    >>> [run.theta.round(6).tolist() for run in runs]
    [[2.0, -1.0], [2.0, -1.0]]
    """
    passes = range(max_iter + 1)
    for _ in passes if ticks is None else ticks(passes):
        active = [run for run in runs if not run.done]
        if not active:
            return
        if time.perf_counter() > deadline and all(run.r is not None for run in active):
            return
        plan, trials = _plan_pass(problem, active, max_iter, options)
        if not trials:
            return
        results = problem.evaluate(trials)
        for run, first, count, step in plan:
            run.n_eval += 1
            got = results[first : first + count]
            if step:
                _take_step(problem, run, trials[first : first + count], got, options)
            else:
                _take_evaluation(problem, run, got[0], options)


def _plan_pass(
    problem: LMProblem, active: Sequence[Any], max_iter: int, o: LMOptions
) -> tuple[list[tuple[Any, int, int, bool]], list[Trial]]:
    """The trials of one pass, and per run ``(run, first trial, trials, is a step)``.

    A run without a Jacobian is evaluated where it is (one trial: its own ``theta``);
    the others get one trial per damping factor.
    """
    plan, trials = [], []
    for run in active:
        if run.J is None:
            if run.n_iter >= max_iter and run.r is not None:
                continue
            plan.append((run, len(trials), 1, False))
            trials.append(Trial(run, run.theta, run.x0, True))
            continue
        if run.n_iter >= max_iter:
            continue
        lo, hi, x0_lo = problem.bounds(run)
        free = ~_held(run.J, run.r, run.theta, lo, hi) if o.hold_bounds else None
        normal = _NormalEquations(run.J, run.r, run.Jx, free)
        plan.append((run, len(trials), len(o.trials), True))
        for i, f in enumerate(o.trials):
            dth, dx0 = normal.step(f * run.lam)
            theta = np.clip(run.theta + dth, lo, hi)
            x0 = None
            if run.x0 is not None:
                dx0 = np.zeros_like(run.x0) if dx0 is None else dx0
                x0 = np.maximum(run.x0 + dx0, x0_lo[None, :])
            trials.append(Trial(run, theta, x0, i < o.trial_jacobians))
    return plan, trials


def _take_evaluation(problem: LMProblem, run, ev: Evaluation, o: LMOptions) -> None:
    """Residuals and Jacobian at the run's own point (its start, or after a step)."""
    run.r, run.J, run.Jx = ev.r, ev.J, ev.Jx
    run.cost = half_squares(ev.r)
    if not math.isfinite(run.cost):
        run.done = True
        return
    if o.test_at_start:
        _test_stop(problem, run, math.inf, None, o)


def _take_step(
    problem: LMProblem,
    run,
    trials: Sequence[Trial],
    got: Sequence[Evaluation],
    o: LMOptions,
) -> None:
    """Move the run to its best trial if that lowers the cost; adapt the damping."""
    run.n_iter += 1
    costs = [half_squares(ev.r) for ev in got]
    best = int(np.argmin(costs))
    old = run.cost
    if not costs[best] < old:
        run.lam = o.after_reject * run.lam
        if run.lam > o.give_up:
            run.done = True
        return
    before = None
    if o.xtol is not None:
        before = _flat(run.theta, run.x0)
    trial, ev = trials[best], got[best]
    run.theta, run.x0 = trial.theta, trial.x0
    run.r, run.cost, run.J, run.Jx = ev.r, costs[best], ev.J, ev.Jx
    if ev.J is None and o.refresh_now:
        now = problem.evaluate([Trial(run, run.theta, run.x0, True)])[0]
        run.r, run.J, run.Jx = now
        run.cost = half_squares(now.r)
    multiply, divide = o.after_accept[best]
    run.lam = min(max(run.lam * multiply / divide, o.lam_min), o.lam_max)
    _test_stop(problem, run, old, before, o)


def _flat(theta: np.ndarray, x0: np.ndarray | None) -> np.ndarray:
    """``theta`` and ``x0`` in one vector."""
    return theta if x0 is None else np.concatenate([theta, x0.ravel()])


def _test_stop(problem: LMProblem, run, old: float, before, o: LMOptions) -> None:
    """Record the cost and apply the stop rules after a step (``old``: the cost before)."""
    run.history.append(run.cost)
    if o.offset_tol is not None:
        lo, hi, _ = problem.bounds(run)
        run.offset = relative_offset(run.J, run.r, run.cost, run.theta, lo, hi)
    rel = (old - run.cost) / max(abs(old), 1e-300) if math.isfinite(old) else 1.0
    tiny = False
    if before is not None:
        after = _flat(run.theta, run.x0)
        tiny = np.linalg.norm(after - before) <= o.xtol * (np.linalg.norm(after) + o.xtol)
    run.small = run.small + 1 if (rel < o.ftol or tiny) else 0
    if o.offset_tol is not None and run.offset < o.offset_tol:
        run.done = True
    elif run.small >= 2 or run.cost < o.cost_floor:
        run.done = True
