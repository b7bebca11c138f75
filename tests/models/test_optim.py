"""The shared batched Levenberg-Marquardt of ``models/_optim.py`` against scipy.

``scipy.optimize.least_squares(method="lm")`` (MINPACK) is the reference on problems with
known solutions: Rosenbrock, an exponential fit, several starts that end in different
minima, a parameter held fixed and a bound that is active at the optimum (scipy's
``"trf"`` there, MINPACK has no bounds). Both damping schedules the callers use (the
piston twin's and mismatch discovery's) are run. On an active bound the callers' clipped
step stalls a little short of the optimum (within 0.2 %); holding the coordinates on a
bound (``hold_bounds``) reaches it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from pdmkit.models._optim import (
    FunctionProblem,
    LMOptions,
    LMRun,
    Trial,
    covariance,
    damped_step,
    gauss_newton_step,
    half_squares,
    levenberg_marquardt,
    relative_offset,
)

#: the piston twin's schedule (lambda/10, lambda, 10 lambda; Jacobian at every trial)
TWIN = LMOptions(ftol=1e-12, offset_tol=1e-10, test_at_start=True)
#: mismatch discovery's (lambda, 10 lambda; lambda/3 or 2 lambda after a step)
MISMATCH = LMOptions(
    trials=(1.0, 10.0),
    after_accept=((1.0, 3.0), (2.0, 1.0)),
    lam_min=1e-9,
    lam_max=math.inf,
    after_reject=10.0,
    give_up=1e10,
    trial_jacobians=1,
    ftol=1e-12,
    xtol=1e-12,
    cost_floor=1e-30,
)
SCHEDULES = pytest.mark.parametrize("options", [TWIN, MISMATCH], ids=["twin", "mismatch"])


def _rosenbrock(th):
    return np.array([10.0 * (th[1] - th[0] ** 2), 1.0 - th[0]])


def _rosenbrock_jac(th):
    return np.array([[-20.0 * th[0], 10.0], [-1.0, 0.0]])


def _held(options):
    return dataclasses.replace(options, hold_bounds=True)


def _fit(fun, starts, options, max_iter=200, **kw):
    runs = [LMRun(np.array(s, dtype=float)) for s in starts]
    levenberg_marquardt(FunctionProblem(fun, **kw), runs, max_iter, options)
    return runs


@SCHEDULES
def test_rosenbrock_reaches_the_minimum_as_minpack_does(options):
    ref = least_squares(_rosenbrock, [-1.2, 1.0], jac=_rosenbrock_jac, method="lm")
    (run,) = _fit(_rosenbrock, [[-1.2, 1.0]], options, jac=_rosenbrock_jac)
    np.testing.assert_allclose(run.theta, ref.x, atol=1e-7)
    np.testing.assert_allclose(run.theta, [1.0, 1.0], atol=1e-7)
    assert run.cost < 1e-14
    assert run.history == sorted(run.history, reverse=True)  # every step lowers it


@SCHEDULES
def test_exponential_fit_matches_minpack(options):
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 4.0, 60)
    y = 2.5 * np.exp(-1.3 * t) + 0.4 + 0.01 * rng.normal(size=t.size)

    def fun(th):
        return th[0] * np.exp(th[1] * t) + th[2] - y

    ref = least_squares(fun, [1.0, -0.5, 0.0], method="lm", xtol=1e-14, ftol=1e-14)
    (run,) = _fit(fun, [[1.0, -0.5, 0.0]], options)
    np.testing.assert_allclose(run.theta, ref.x, rtol=1e-6)
    assert run.cost == pytest.approx(ref.cost, rel=1e-9)
    # the covariance at the optimum is s^2 (J^T J)^-1 (a step taken without its
    # Jacobian, as mismatch's second trial, gets it in the next pass: evaluate it here)
    run.r, run.J, _ = FunctionProblem(fun).evaluate([Trial(run, run.theta, None, True)])[0]
    cov, s2 = covariance(run.J, run.cost)
    assert s2 == pytest.approx(2 * ref.cost / (t.size - 3), rel=1e-9)
    np.testing.assert_allclose(cov, s2 * np.linalg.inv(ref.jac.T @ ref.jac), rtol=1e-4)
    assert relative_offset(run.J, run.r, run.cost) < 1e-8


@SCHEDULES
def test_a_batch_of_starts_ends_in_the_minimum_nearest_each(options):
    # r = (x^2 - 1, y^2 - 4): four minima (+-1, +-2), one per quadrant
    def fun(th):
        return np.array([th[0] ** 2 - 1.0, th[1] ** 2 - 4.0])

    starts = [[0.5, 0.5], [-0.5, 3.0], [2.0, -1.0], [-3.0, -3.0]]
    runs = _fit(fun, starts, options)
    for start, run in zip(starts, runs, strict=True):
        ref = least_squares(fun, start, method="lm")
        np.testing.assert_allclose(run.theta, ref.x, atol=1e-7)
        np.testing.assert_allclose(run.theta, np.sign(start) * [1.0, 2.0], atol=1e-7)
        assert run.done


@SCHEDULES
def test_a_parameter_held_by_equal_bounds_stays_and_the_rest_fit(options):
    t = np.linspace(0.0, 2.0, 30)
    y = 3.0 * np.exp(-0.7 * t) + 0.2

    def fun(th):
        return th[0] * np.exp(th[1] * t) + th[2] - y

    lo, hi = [-np.inf, -np.inf, 0.5], [np.inf, np.inf, 0.5]
    ref = least_squares(lambda ab: fun([ab[0], ab[1], 0.5]), [1.0, -0.1], method="lm")
    (held,) = _fit(fun, [[1.0, -0.1, 0.5]], _held(options), lo=lo, hi=hi)
    assert held.theta[2] == 0.5
    np.testing.assert_allclose(held.theta[:2], ref.x, rtol=1e-7)
    (clipped,) = _fit(fun, [[1.0, -0.1, 0.5]], options, lo=lo, hi=hi)
    assert clipped.theta[2] == 0.5
    np.testing.assert_allclose(clipped.theta[:2], ref.x, rtol=2e-3)
    # the restricted Gauss-Newton step moves only the free coordinates
    ev = FunctionProblem(fun).evaluate([Trial(held, held.theta, None, True)])[0]
    step = gauss_newton_step(ev.J, ev.r, np.array([False, False, True]))
    assert step[2] == 0.0 and np.all(np.abs(step[:2]) < 1e-7)


@SCHEDULES
def test_an_active_bound_is_kept_and_the_other_parameter_is_optimal(options):
    # unconstrained optimum (1, 1); the bound x <= 0.5 binds: (0.5, 0.25)
    lo, hi = [-np.inf, -np.inf], [0.5, np.inf]
    ref = least_squares(
        _rosenbrock, [-1.2, 1.0], jac=_rosenbrock_jac, bounds=(lo, hi), method="trf"
    )
    kw = {"jac": _rosenbrock_jac, "lo": lo, "hi": hi}
    (held,) = _fit(_rosenbrock, [[-1.2, 1.0]], _held(options), **kw)
    np.testing.assert_allclose(held.theta, ref.x, atol=1e-7)
    assert held.theta[0] == 0.5
    # on the bound the step pushing outwards is held: the relative offset is ~0
    box = np.array(lo), np.array(hi)
    ev = FunctionProblem(_rosenbrock, _rosenbrock_jac).evaluate(
        [Trial(held, held.theta, None, True)]
    )[0]
    assert relative_offset(ev.J, ev.r, held.cost, held.theta, *box) < 1e-8
    (clipped,) = _fit(_rosenbrock, [[-1.2, 1.0]], options, **kw)
    assert clipped.theta[0] == 0.5
    np.testing.assert_allclose(clipped.theta, ref.x, rtol=2e-3)


def test_block_step_equals_the_dense_damped_step():
    # 3 pieces of 5 residuals, 2 shared parameters, 2 per-piece parameters
    rng = np.random.default_rng(1)
    K, mk, n, nx = 3, 5, 2, 2
    J, r = rng.normal(size=(K * mk, n)), rng.normal(size=K * mk)
    Jx = rng.normal(size=(K, mk, nx))
    full = np.zeros((K * mk, n + K * nx))
    full[:, :n] = J
    for k in range(K):
        full[k * mk : (k + 1) * mk, n + k * nx : n + (k + 1) * nx] = Jx[k]
    for lam in (0.0, 1e-3, 10.0):
        dth, dx = damped_step(J, r, lam, Jx)
        A = full.T @ full
        D = np.clip(np.diag(A), 1e-12 * np.max(np.diag(A)), None)
        ref = np.linalg.solve(A + lam * np.diag(D), -full.T @ r)
        np.testing.assert_allclose(dth, ref[:n], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(dx.ravel(), ref[n:], rtol=1e-9, atol=1e-12)


def test_a_start_that_cannot_be_evaluated_stops_and_the_others_go_on():
    def fun(th):
        return np.array([th[0] - 2.0]) if th[0] > 0 else np.array([np.nan])

    bad, good = _fit(fun, [[-1.0], [1.0]], TWIN)
    assert bad.done and bad.cost == math.inf and bad.n_iter == 0
    assert good.theta[0] == pytest.approx(2.0)


def test_iterations_are_capped_and_counted_over_calls():
    runs = _fit(_rosenbrock, [[-1.2, 1.0]], TWIN, max_iter=3, jac=_rosenbrock_jac)
    assert runs[0].n_iter == 3 and not runs[0].done
    levenberg_marquardt(FunctionProblem(_rosenbrock, _rosenbrock_jac), runs, 200, TWIN)
    np.testing.assert_allclose(runs[0].theta, [1.0, 1.0], atol=1e-7)
    assert runs[0].n_iter > 3
    # mismatch's schedule spends a pass on the Jacobian after a step without one
    runs = _fit(_rosenbrock, [[-1.2, 1.0]], MISMATCH, max_iter=3, jac=_rosenbrock_jac)
    assert runs[0].n_iter + sum(run.J is None for run in runs) <= 3


def test_half_squares_is_inf_for_a_diverged_trial():
    assert half_squares(np.array([1e200, 1e200])) == math.inf
    assert half_squares(np.array([np.nan])) == math.inf
    assert half_squares(np.array([1.0, 2.0])) == 2.5


def test_a_jacobian_whose_squares_overflow_gives_a_failed_step_not_an_error():
    # far out in a diverging trial a finite-difference column can reach 1e200: its
    # normal equations overflow; the step must be NaN (a rejected trial), not raise
    # LinAlgError('SVD did not converge') from the batched pseudo-inverse
    from pdmkit.models._optim import _NormalEquations

    J = np.ones((6, 2))
    Jx = np.full((2, 3, 1), 1e200)
    r = np.ones(6)
    dth, dx = _NormalEquations(J, r, Jx)._step(1e-2)
    assert np.all(np.isnan(dth)) and np.all(np.isnan(dx))
    dth, dx = _NormalEquations(np.full((6, 2), 1e200), r)._step(1e-2)
    assert np.all(np.isnan(dth)) and dx is None
