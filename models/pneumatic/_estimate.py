"""Parameter estimation of the pneumatic twin by simulation-error minimisation (seed 4.7).

The seed re-estimates six parameters per fault condition (table 4.2): the valve
coefficients C_A,in, C_A,out, C_B,in, C_B,out and the small end dampers b_up, b_bot.
:func:`estimate_parameters` does this (or frees any other dynamic parameter) by
minimising the simulation error of selected sensor signals over *windows*: short
stretches that start at rest just before each switch of the valve command and end when
the piston has settled at the other end. Each window starts from the state the model
reaches there (at rest: the chamber and reservoir pressures have equalised), so the
windows are simulated independently, in one batch, at the fixed step of the twin's
integrator.

Method

* Parameters that must be positive are optimised in log space, all within bounds (the
  dataclass ranges, or two decades either side of the known value where the range is
  open).
* Residuals are ``(model - measured) / sigma`` per signal, ``sigma`` from the noise of
  the measured signal (robust, from second differences, floored at 1e-3 of its range),
  so that flows in l/min and positions in m weigh by their information, not their unit.
  After the fit ``sigma`` is re-estimated from the residuals and the fit repeated when it
  moved (feasible weighted least squares), so the covariance below is calibrated.
* A batched Levenberg-Marquardt runs all starts at once: the known values plus
  Latin-hypercube starts in log space. Stage 1 uses a coarse step (5e-4 s) to find the
  basin; stage 2 refines the best start at the integrator's step (2e-4 s).
* Jacobians: ``jacobian="autograd"`` differentiates the integrator with torch (reverse
  mode twice, which gives the forward sensitivities d residual / d parameter of all
  parameters at once); ``"fd"`` uses central differences of the numpy integrator,
  batched as extra members. They agree to 1e-8..2e-6 (relative, per column). ``"fd"``
  is the default because it is much faster here: on a 2-core machine a Jacobian of
  the default problem (2 windows of 375 samples at 2e-4 s) takes 0.2 s by batched
  differences and 19 s by autograd (torch's per-operation overhead dominates at these
  batch sizes; its forward mode is slower still), a whole fit 5 s against 73 s, with
  the same estimates to four digits.
* Covariance ``s^2 (J^T J)^-1`` of the log parameters at the optimum, with ``s^2`` the
  residual variance; 95 % intervals ``exp(z +- t se)`` (positive parameters) or
  ``theta +- t se``. Directions of ``J^T J`` with (numerically) zero curvature make the
  parameters involved unidentifiable: their standard error is reported as infinite.
"""

from __future__ import annotations

import math
import time as _time
import warnings
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit._optional import require
from pdmkit.errors import ConvergenceWarning, ModelError
from pdmkit.models._optim import covariance, half_squares, relative_offset
from pdmkit.models.pneumatic._estimate_inputs import _setup_problem
from pdmkit.models.pneumatic._estimate_problem import (
    _levenberg_marquardt,
    _Problem,
    _Run,
)
from pdmkit.models.pneumatic._estimate_result import (
    EstimationResult,
    _estimation_result,
)
from pdmkit.models.pneumatic._twin import PneumaticParams

if TYPE_CHECKING:
    from pdmkit.models.pneumatic._integrate import PneumaticResponse

__all__ = ["DEFAULT_FREE", "DEFAULT_SIGNALS", "EstimationResult", "estimate_parameters"]

#: the parameters the seed re-estimates per fault condition (table 4.2)
DEFAULT_FREE = (
    "c_a_in",
    "c_a_out",
    "c_b_in",
    "c_b_out",
    "damper_upper",
    "damper_bottom",
)
#: sensors fitted by default: the encoder (motion, end dampers), the two flow sensors of
#: chamber A (C_A,in, C_A,out) and the supply pressure (draw through C_B,in)
DEFAULT_SIGNALS = ("LeverPosition", "FlowExtrusion", "FlowContraction", "AirPressure")

_COARSE_ITER = 20  # iterations of the search stage (refinement: max_iter)
_CONVERGED = 0.25  # remaining Gauss-Newton step, squared standard errors


def _latin_hypercube(rng: np.random.Generator, n: int, p: int) -> np.ndarray:
    """``n`` points of a Latin hypercube in the unit cube of dimension ``p``."""
    cut = (np.arange(n)[:, None] + rng.random((n, p))) / n
    for j in range(p):
        cut[:, j] = cut[rng.permutation(n), j]
    return cut


# ---------------------------------------------------------------------------- public
def estimate_parameters(
    recording: Mapping[str, Any] | PneumaticResponse,
    *,
    free: Sequence[str] = DEFAULT_FREE,
    known: PneumaticParams | None = None,
    signals: Sequence[str] = DEFAULT_SIGNALS,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    n_starts: int = 4,
    window: float | str = "auto",
    max_windows: int | None = 2,
    member: int = 0,
    dt: float = 2e-4,
    jacobian: str = "fd",
    max_iter: int = 40,
    seed: int | None = 0,
    progress: bool | None = None,
) -> EstimationResult:
    """Estimate parameters of the pneumatic twin from a recording (seed 4.7).

    Simulation-error minimisation over windows that start at rest just before each
    switch of the valve command and last until the piston has settled at the other end
    (so the end dampers, which act on the last ``damper_small_travel`` = 8 mm of each
    stroke, are in every window). A batched Levenberg-Marquardt runs ``n_starts``
    starts in log space at a coarse step, then refines the best one at the step ``dt``
    of the twin's integrator; the confidence intervals come from the Jacobian at the
    optimum, ``s^2 (J^T J)^-1``. See the module notes for the details.

    Parameters
    ----------
    recording : mapping or PneumaticResponse
        Sensor readings at a uniform rate starting at t = 0 of the valve command schedule
        in ``known``: a mapping of signal name -> 1-D array with an ``"fs"`` entry
        (Hz), or a :class:`PneumaticResponse` (its ``outputs`` of member ``member``).
        Signal names and units as :data:`SENSOR_UNITS` (seed table 3.1).
    free : sequence of str
        PneumaticParams fields to estimate; default the six of seed table 4.2 (valve
        coefficients and the two small damper settings 1..10).
    known : PneumaticParams, optional
        Every other parameter (scalar). Its values of the free parameters are the first
        start. Default ``PneumaticParams()``.
    signals : sequence of str
        Sensors to fit, from :data:`FITTABLE_SIGNALS`. The default uses the encoder, both
        flow sensors of chamber A and the supply pressure.
    bounds : dict of str to (float, float), optional
        Bounds per free parameter (its unit). Default: the PneumaticParams range, within
        two decades of the known value where the range is open.
    n_starts : int
        Starting points (the known values, then a Latin hypercube over the bounds, at
        most half a decade from the known value), all fitted in one batch.
    window : "auto" or float
        Window length in s after each switch; "auto" measures the slowest arrival at the
        end stop in ``LeverPosition`` (else in a simulation of ``known``) and adds 0.1 s.
    max_windows : int or None
        Use the first this many windows; default 2 (one up and one down stroke), None:
        every switch in the recording (more data, longer fit).
    member : int
        Member of a batched PneumaticResponse.
    dt : float
        Integration step of the refinement, s; ``1 / (fs dt)`` must be whole.
    jacobian : {"fd", "autograd"}
        Jacobian source of the refinement: central differences of the numpy integrator
        (batched) or torch autograd through the integrator (exact; a fit takes about 15
        times longer). The search stage always uses differences.
    max_iter : int
        Iterations of the refinement (the coarse search stops after at most 20).
    seed : int, optional
        Seed of the Latin-hypercube starts.
    progress : bool, optional
        Progress bar (default: only on a terminal).

    Returns
    -------
    EstimationResult

    Raises
    ------
    ModelError
        Unknown or unfittable free parameter, bad bounds, window or settings.
    DataError
        Missing signal, non-finite samples, signals of unequal length, no ``fs``.

    Warns
    -----
    ConvergenceWarning
        When the refinement ends more than half a standard error from the optimum;
        it names the parameters the chosen signals cannot determine.

    Notes
    -----
    The window states come from a simulation of ``known`` (at the current estimate)
    from rest at t = 0, so the recording must start there too, as :func:`simulate_piston`'s
    do; the windows themselves start at rest, where those states hardly depend on the
    free parameters.

    The intervals express the sensor noise only: they assume the model and ``known``
    are right. A wrong known value biases the estimates far beyond them (hidden member
    above, 2 windows: Coulomb friction 12 N instead of the known 10 N moved C_B,in by
    -18 %, a moving mass 10 % heavier C_A,in by -4 %, data integrated at 1e-4 s
    instead of 2e-4 s C_A,in by -1.5 %); the fit then usually stalls with a
    ConvergenceWarning. Freeing the doubtful parameter as well recovered all seven
    within 0.1 % in both cases.

    Which sensors determine which parameters (six free, hidden member with every
    valve and damper off its default, default sensor noise, 95 % CI half-widths):
    ``LeverPosition`` alone determines all six (the 7 um encoder; <= 0.07 %);
    ``FlowExtrusion`` alone only C_A,in, C_B,out and the upper damper (the up stroke),
    ``FlowContraction`` alone only C_A,out, C_B,in and the bottom damper (the down
    stroke); the others come back with infinite intervals and ``identifiable`` False.
    ``AirPressure`` alone sees all six but weakly (up to +-85 % for the bottom
    damper); the two flows and the pressure together give all six within +-3.2 %.

    Examples
    --------
    Recover the inflow valve coefficient of chamber A from the flow sensor of one
    up-stroke of a simulated member whose C_A,in is 30 % high:

    >>> from pdmkit.models import PneumaticParams, estimate_parameters, simulate_piston
    >>> truth = PneumaticParams(c_a_in=6.5e-6)
    >>> rec = simulate_piston(truth, t_end=0.5, seed=2, sensors=["LeverPosition",
    ...                "FlowExtrusion"])
    >>> res = estimate_parameters(rec, free=["c_a_in"], signals=["FlowExtrusion"],
    ...                           n_starts=2, max_windows=1)
    >>> res.converged, abs(res.estimates["c_a_in"] / 6.5e-6 - 1) < 0.05
    (True, True)
    >>> lo, hi = res.ci95["c_a_in"]
    >>> bool(lo < 6.5e-6 < hi)
    True
    """
    t_start = _time.perf_counter()
    _check_settings(jacobian, n_starts, max_iter)
    prob, data = _setup_problem(
        recording, free, known, signals, bounds, window, max_windows, member, dt
    )
    Z0 = _starting_points(prob, n_starts, seed)
    runs = _search(prob, Z0, max_iter, progress)
    best = min(runs, key=lambda r: r.cost)
    history = list(best.history)
    fine = _refine(prob, data, best, max_iter, jacobian, progress, history)
    offset = relative_offset(fine.J, fine.r, fine.cost, fine.theta, prob.lo, prob.hi)
    # the refinement aims at 0.01 standard error; where the fixed-step map is too rough
    # for that (impacts, contacts switching within a step) it stalls a little short:
    # half a standard error still counts (it adds at most ~12 % to the error's spread)
    converged = offset < _CONVERGED
    if not converged:
        _warn_stalled(prob, fine, offset, max_iter)
    return _estimation_result(
        prob, fine, runs, Z0, history, offset, bool(converged), t_start
    )


def _check_settings(jacobian: str, n_starts, max_iter) -> None:
    """Check the optimiser's settings (the problem's inputs: :func:`_setup_problem`)."""
    if jacobian not in ("fd", "autograd"):
        raise ModelError(
            f"estimate_parameters: jacobian must be 'fd' or 'autograd'; got {jacobian!r}."
        )
    if jacobian == "autograd":  # before the search stage, not minutes into the fit
        require("torch", what="estimate_parameters(jacobian='autograd')")
    if not isinstance(n_starts, int | np.integer) or n_starts < 1:
        raise ModelError(
            f"estimate_parameters: n_starts must be a positive integer; got {n_starts!r}."
        )
    if not isinstance(max_iter, int | np.integer) or max_iter < 1:
        raise ModelError(
            f"estimate_parameters: max_iter must be a positive integer; got {max_iter!r}."
        )


def _starting_points(prob: _Problem, n_starts: int, seed) -> np.ndarray:
    """The known values, then a Latin hypercube within half a decade: ``(n_starts, p)``."""
    known, names, log, lo, hi = prob.known, prob.names, prob.log, prob.lo, prob.hi
    z_known = prob.encode(np.array([float(getattr(known, k)) for k in names]))
    half_decade = np.where(log, math.log(10.0) / 2.0, np.inf)
    s_lo = np.maximum(lo, z_known - half_decade)
    s_hi = np.minimum(hi, z_known + half_decade)
    s_lo = np.where(np.isfinite(s_lo), s_lo, lo)
    s_hi = np.where(np.isfinite(s_hi), s_hi, hi)
    rng = np.random.default_rng(seed)
    Z0 = np.empty((n_starts, prob.p))
    Z0[0] = z_known
    if n_starts > 1:
        Z0[1:] = s_lo + _latin_hypercube(rng, n_starts - 1, prob.p) * (s_hi - s_lo)
    return Z0


def _search(prob: _Problem, Z0: np.ndarray, max_iter: int, progress) -> list[_Run]:
    """Stage 1: every start at the coarse step, in one batch."""
    Y0 = prob.window_states(Z0)
    runs = [_Run(theta=Z0[i].copy(), y0=Y0[i]) for i in range(Z0.shape[0])]
    # the coarse model differs from the data by its step error anyway: stop once the
    # cost stalls (relative decrease below 1e-4 twice) or the step is within one SE
    _levenberg_marquardt(
        prob,
        runs,
        prob.n_sub_coarse,
        min(max_iter, _COARSE_ITER),
        1.0,
        1e-4,
        "fd",
        "estimate (coarse)",
        progress,
    )
    if not math.isfinite(min(run.cost for run in runs)):
        raise ModelError(
            "estimate_parameters: every start failed to simulate (non-finite readings); "
            "check `known` and narrow the bounds."
        )
    return runs


def _refine(
    prob: _Problem,
    data: Mapping[str, np.ndarray],
    best: _Run,
    max_iter: int,
    jacobian: str,
    progress,
    history: list,
) -> _Run:
    """Stage 2: the best start at the integrator's step, re-estimating the weights.

    ``sigma`` (``prob.sigma``, updated) is re-estimated from the residuals until it
    settles (feasible weighted least squares); ``history`` is extended with the costs.
    Returns the refined run, its residuals and Jacobian weighted by the final sigma.
    """
    signals = prob.signals
    z = best.theta.copy()
    y0 = prob.window_states(z[None])[0]
    fine = _Run(theta=z, y0=y0, lam=1e-4)
    block = prob.n_windows * (prob.length - 1)  # residuals per signal
    for rnd in range(4):
        # the weights move after the first round: converge loosely until they settle
        tol = 1e-4 if rnd > 0 else 1.0
        if fine.J is not None:
            fine.offset = relative_offset(
                fine.J, fine.r, fine.cost, fine.theta, prob.lo, prob.hi
            )
            fine.done = fine.offset < tol
        _levenberg_marquardt(
            prob,
            [fine],
            prob.n_sub_fine,
            max_iter,
            tol,
            1e-12,
            jacobian,
            "estimate (fine)",
            progress,
        )
        history.extend(fine.history)
        res = fine.r.reshape(len(signals), -1) * prob.sigma[:, None]
        rms = np.sqrt(np.nanmean(res**2, axis=1))
        floor = np.array([1e-5 * max(float(np.ptp(data[s])), 1e-12) for s in signals])
        new_sigma = np.maximum(rms, floor)
        ratio = new_sigma / prob.sigma
        # same point, new weights: rescale residuals and Jacobian rows per signal
        rows = np.repeat(1.0 / ratio, block)
        prob.sigma = new_sigma
        fine = _Run(
            theta=fine.theta,
            y0=y0,
            lam=fine.lam,
            r=fine.r * rows,
            J=fine.J * rows[:, None],
            n_iter=fine.n_iter,
        )
        fine.cost = half_squares(fine.r)
        if rnd > 0 and np.all((ratio > 1 / 1.2) & (ratio < 1.2)):
            break
    return fine


def _warn_stalled(prob: _Problem, fine: _Run, offset: float, max_iter: int) -> None:
    """ConvergenceWarning: why the refinement stopped short, and what cannot be seen."""
    cov, _ = covariance(fine.J, fine.cost)
    blind = [k for j, k in enumerate(prob.names) if not np.isfinite(cov[j, j])]
    hint = (
        f" {', '.join(blind)} cannot be determined from {', '.join(prob.signals)}: fix "
        "them in `known` or add a sensor that sees them."
        if blind
        else ""
    )
    if fine.n_iter >= max_iter:
        why = f"raise max_iter (now {max_iter}) or narrow the bounds."
    else:
        why = (
            "the cost no longer decreases along it, which usually means the model "
            "does not match the data: check `known` (free a doubtful parameter) and "
            "the sensors' calibration."
        )
    warnings.warn(
        f"estimate_parameters: the refinement stopped after {fine.n_iter} iterations "
        f"with the Gauss-Newton step still {math.sqrt(offset):.2g} standard errors "
        f"long; {why}{hint}",
        ConvergenceWarning,
        stacklevel=3,
    )
