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

import dataclasses
import math
import time as _time
import types
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit._progress import progress
from pdmkit.errors import ConvergenceWarning, DataError, ModelError, did_you_mean
from pdmkit.models._xp import TorchNamespace, get_namespace
from pdmkit.models.ode import ResponseData
from pdmkit.models.pneumatic._integrate import _THETA, _switch_times, simulate_piston
from pdmkit.models.pneumatic._sensors import P_STD, SENSOR_UNITS, T_STD
from pdmkit.models.pneumatic._twin import PneumaticParams, _command, _derivs, _resolve

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

#: sensors whose readings the estimator can predict differentiably
FITTABLE_SIGNALS = (
    "LeverPosition",
    "LeverVelocity",
    "AccelerometerMoving_axisZ",
    "FlowExtrusion",
    "FlowContraction",
    "AirPressure",
)

#: parameters that only shape sensor readings the estimator does not fit
_SENSOR_ONLY = frozenset(
    {
        "frame_frequency",
        "frame_damping_ratio",
        "frame_mass",
        "strain_area",
        "mic_frequency",
        "mic_decay",
        "mic_gain",
        "mic_far_gain",
        "mic_ambient_gain",
        "mic_hiss_gain",
        "proximity_distance",
        "temp_gas_time_constant",
        "temp_wall_gain",
        "temp_sensor_time_constant",
    }
)
#: parameters that move the valve switching instants: a fixed-step simulation is
#: piecewise constant in them (no gradient)
_TIMING = frozenset({"cycle_period", "cycle_duty", "cycle_start", "valve_delay"})

_RHO_STD = P_STD / (287.1 * T_STD)  # as the flow sensors of _sensors.ideal_readings
_TO_LPM = 60000.0 / _RHO_STD
_COARSE_DT = 5e-4  # stage-1 step: rest states identical to 2e-4, flows within ~1.5 %
_PRE_SWITCH = 0.005  # s of rest kept before each switch
_SETTLE_TOL = 2e-4  # m: the piston has arrived when within this of its rest position
_MARGIN = 0.1  # s kept after the slowest arrival (chamber filling, damper creep)
_FD_STEP = 1e-5  # central-difference step in the transformed (log) parameters
_COARSE_ITER = 20  # iterations of the search stage (refinement: max_iter)
_CONVERGED = 0.25  # remaining Gauss-Newton step, squared standard errors
_NULL = 1e-12  # relative curvature below which a direction counts as unidentifiable


# ---------------------------------------------------------------------------- windows
def _command_table(known: PneumaticParams, t0: np.ndarray, n_steps: int, h: float):
    """Delayed valve command at every step of every window: (n_steps, n_windows)."""
    ns = types.SimpleNamespace(
        cycle_start=known.cycle_start,
        cycle_period=known.cycle_period,
        cycle_duty=known.cycle_duty,
    )
    t = t0[None, :] + np.arange(n_steps)[:, None] * h - known.valve_delay
    return np.ascontiguousarray(_command(t, ns, np))


def _run_windows(params, y0, u_table, n_samples: int, n_sub: int, h: float, xp):
    """Step members from ``y0`` (n, 6) with the integrator of :func:`simulate_piston`.

    The same IMEX step as :func:`pdmkit.models.pneumatic._integrate._integrate` (exact spool
    update, flows at the mid-step spool, explicit pressures, linearly implicit
    trapezoidal mechanics); ``u_table`` (n_steps, n) holds the delayed command. Returns
    position, velocity, supply pressure (at the samples) and the valve mass flow into A
    (mean over each sample interval; 0 at the first sample), each (n, n_samples).
    """
    r = _resolve(params, xp)
    th_h = _THETA * h
    r.imp = th_h * r.inv_m
    t_v = xp.asarray(r.t_v)
    decay = xp.exp(-h / t_v)
    half = xp.exp(-0.5 * h / t_v)
    x, v, pa, pb, pr, s = (y0[:, i] for i in range(6))
    u_all = xp.asarray(u_table)
    zero = 0.0 * x
    rec_x, rec_v, rec_pr, rec_ma = [x], [v], [pr], [zero]
    inv = 1.0 / n_sub
    step = 0
    for _ in range(1, n_samples):
        s_ma = zero
        for _j in range(n_sub):
            u = u_all[step]
            s_u = s - u
            d = _derivs(0.0, x, v, pa, pb, pr, u + s_u * half, r, xp, aux=True)
            dv = h * (d.acc - d.k_eff * v) / (1.0 + d.c_eff + th_h * d.k_eff)
            x = x + h * (v + _THETA * dv)
            v = v + dv
            pa = pa + h * d.dpa
            pb = pb + h * d.dpb
            pr = pr + h * d.dpr
            s = u + s_u * decay
            s_ma = s_ma + d.m_a
            step += 1
        rec_x.append(x)
        rec_v.append(v)
        rec_pr.append(pr)
        rec_ma.append(s_ma * inv)
    return {
        "position": xp.stack(rec_x, axis=1),
        "velocity": xp.stack(rec_v, axis=1),
        "pressure_supply": xp.stack(rec_pr, axis=1),
        "mass_flow_a": xp.stack(rec_ma, axis=1),
    }


def _readings(raw, name: str, p_ambient, fs: float, xp):
    """Noise-free reading of one sensor, as the sensor models of the twin give it."""
    if name == "LeverPosition":
        return raw["position"]
    if name == "LeverVelocity":
        return raw["velocity"]
    if name == "AccelerometerMoving_axisZ":
        v = raw["velocity"]
        return xp.concat([0.0 * v[:, :1], (v[:, 1:] - v[:, :-1]) * fs], axis=1)
    if name == "FlowExtrusion":
        return xp.relu(raw["mass_flow_a"]) * _TO_LPM
    if name == "FlowContraction":
        return xp.relu(-raw["mass_flow_a"]) * _TO_LPM
    if name == "AirPressure":
        p0 = p_ambient[:, None] if hasattr(p_ambient, "shape") else p_ambient
        return (raw["pressure_supply"] - p0) / 1e5
    raise AssertionError(name)  # pragma: no cover  (names are validated up front)


# ---------------------------------------------------------------------------- problem
@dataclasses.dataclass
class _Problem:
    """The fit: free parameters, their space and bounds, the windows and the data."""

    known: PneumaticParams
    names: list[str]
    log: np.ndarray  # (p,) optimised as log(theta)
    lo: np.ndarray  # (p,) bounds in the optimised space
    hi: np.ndarray
    th_lo: np.ndarray  # (p,) bounds in the parameter's unit
    th_hi: np.ndarray
    signals: list[str]
    fs: float
    k0: np.ndarray  # (W,) first sample of each window
    length: int  # samples per window (the first one is the given state, not fitted)
    meas: np.ndarray  # (S, W, L) measured readings
    sigma: np.ndarray  # (S,) residual scale of each signal
    h_fine: float
    n_sub_fine: int
    n_sub_coarse: int

    @property
    def p(self) -> int:
        return len(self.names)

    @property
    def n_windows(self) -> int:
        return self.k0.size

    @property
    def n_res(self) -> int:
        return len(self.signals) * self.n_windows * (self.length - 1)

    def theta(self, z: np.ndarray) -> np.ndarray:
        """Parameter values from optimised coordinates (any leading shape)."""
        th = np.where(self.log, np.exp(np.clip(z, -700.0, 700.0)), z)
        return np.clip(th, self.th_lo, self.th_hi)  # exp(log(b)) may round past b

    def encode(self, theta: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(self.log, np.log(np.abs(theta)), theta)
        return np.clip(z, self.lo, self.hi)

    def params_of(self, z: np.ndarray) -> PneumaticParams:
        """Scalar PneumaticParams at one point."""
        th = self.theta(z)
        return self.known.replace(
            **{k: float(v) for k, v in zip(self.names, th, strict=True)}
        )

    # -- simulation
    def predict(self, Z: np.ndarray, y0: np.ndarray, n_sub: int) -> np.ndarray:
        """Readings ``(E, S, W, L)`` at points ``Z`` (E, p); ``y0`` (E, W, 6)."""
        E, W = Z.shape[0], self.n_windows
        th = self.theta(Z)
        changes = {k: np.repeat(th[:, j], W) for j, k in enumerate(self.names)}
        params = self.known.replace(**changes)
        h = 1.0 / (self.fs * n_sub)
        t0 = np.tile(self.k0 / self.fs, E)
        u = _command_table(self.known, t0, (self.length - 1) * n_sub, h)
        xp = get_namespace(1.0)
        with np.errstate(all="ignore"):
            raw = _run_windows(params, y0.reshape(E * W, 6), u, self.length, n_sub, h, xp)
            out = np.stack(
                [_readings(raw, s, params.p_ambient, self.fs, xp) for s in self.signals]
            )
        return out.reshape(len(self.signals), E, W, self.length).transpose(1, 0, 2, 3)

    def residuals(self, Y: np.ndarray) -> np.ndarray:
        """Weighted residuals ``(E, N)`` from readings ``(E, S, W, L)``."""
        R = (Y - self.meas[None]) / self.sigma[None, :, None, None]
        R = R[..., 1:].reshape(Y.shape[0], -1)
        return np.where(np.isfinite(R), R, np.nan)

    def fd_points(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points z, z + d e_j, z - d e_j (one-sided at a bound) and the steps."""
        p = self.p
        d = np.full(p, _FD_STEP)
        d = np.where(self.log, d, _FD_STEP * np.maximum(np.abs(z), 1e-12))
        plus = np.minimum(z + d, self.hi) - z
        minus = z - np.maximum(z - d, self.lo)
        pts = np.empty((1 + 2 * p, p))
        pts[0] = z
        for j in range(p):
            pts[1 + j] = z
            pts[1 + j, j] += plus[j]
            pts[1 + p + j] = z
            pts[1 + p + j, j] -= minus[j]
        return pts, plus, minus

    def fd_jacobian(self, R: np.ndarray, plus: np.ndarray, minus: np.ndarray):
        """Jacobian (N, p) from residuals of the points of :meth:`fd_points`."""
        p = self.p
        J = (R[1 : 1 + p] - R[1 + p :]).T / (plus + minus)[None, :]
        return np.where(np.isfinite(J), J, 0.0)

    def autograd_jacobian(self, z: np.ndarray, y0: np.ndarray, n_sub: int):
        """Residuals (N,) and Jacobian (N, p) at ``z`` by torch autograd.

        One reverse pass with ``create_graph`` gives ``g(u) = J^T u`` for a symbolic
        co-vector ``u``; differentiating ``g`` in ``u`` along each unit vector (a
        batched second reverse pass) gives the columns ``J e_j``: forward sensitivities
        of every residual at the cost of about five forward passes.
        """
        import torch

        W, p = self.n_windows, self.p
        zt = torch.tensor(np.repeat(z[:, None], W, axis=1), dtype=torch.float64)
        zt.requires_grad_(True)
        changes = {}
        for j, k in enumerate(self.names):
            changes[k] = torch.exp(zt[j]) if self.log[j] else zt[j]
        params = self.known.replace(**changes)
        h = 1.0 / (self.fs * n_sub)
        u = _command_table(self.known, self.k0 / self.fs, (self.length - 1) * n_sub, h)
        xp = TorchNamespace()
        y0t = torch.as_tensor(y0.reshape(W, 6), dtype=torch.float64)
        raw = _run_windows(params, y0t, u, self.length, n_sub, h, xp)
        Y = torch.stack(
            [_readings(raw, s, params.p_ambient, self.fs, xp) for s in self.signals]
        )
        meas = torch.as_tensor(self.meas)
        sig = torch.as_tensor(self.sigma)[:, None, None]
        R = ((Y - meas) / sig)[..., 1:]
        co = torch.zeros_like(R, requires_grad=True)
        (g,) = torch.autograd.grad(R, zt, grad_outputs=co, create_graph=True)
        basis = torch.zeros((p, p, W), dtype=torch.float64)
        for j in range(p):
            basis[j, j] = 1.0
        (Jt,) = torch.autograd.grad(g, co, grad_outputs=basis, is_grads_batched=True)
        J = Jt.detach().reshape(p, -1).T.numpy()
        return R.detach().reshape(-1).numpy(), J

    def window_states(self, Z: np.ndarray) -> np.ndarray:
        """Model states at the window starts for points Z (E, p): (E, W, 6).

        A numpy simulation of the recording up to the last window start at the coarse
        step (the windows start at rest, where it agrees with the fine step).
        """
        E = Z.shape[0]
        th = self.theta(Z)
        if E == 1:
            params = self.params_of(Z[0])
        else:
            params = self.known.replace(**{k: th[:, j] for j, k in enumerate(self.names)})
        last = int(self.k0.max())
        h = 1.0 / (self.fs * self.n_sub_coarse)
        kwargs = {"t_end": (last + 1) / self.fs, "fs": self.fs, "sensors": False, "dt": h}
        try:
            r = simulate_piston(
                params, batch=None if E > 1 else 1, progress=False, **kwargs
            )
        except ModelError:
            if E == 1:
                raise
            # a start so extreme that it diverges: every start takes the rest states of
            # the known values (at rest they hardly depend on the free parameters)
            r = simulate_piston(self.known, batch=E, progress=False, **kwargs)
        st = np.stack([np.asarray(r.states[k]) for k in r.states], axis=-1)  # (E, n, 6)
        return st[:, self.k0, :]


# ---------------------------------------------------------------------------- optimiser
@dataclasses.dataclass
class _Run:
    """One start of the batched Levenberg-Marquardt."""

    z: np.ndarray
    y0: np.ndarray  # (W, 6) window start states
    cost: float = math.inf
    r: np.ndarray | None = None
    J: np.ndarray | None = None
    lam: float = 1e-3
    done: bool = False
    converged: bool = False
    n_iter: int = 0
    small: int = 0
    offset: float = math.inf  # GN step length in standard errors, squared
    history: list = dataclasses.field(default_factory=list)


def _cost(r: np.ndarray) -> float:
    c = 0.5 * float(np.dot(r, r))
    return c if math.isfinite(c) else math.inf


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, b, rcond=None)[0]


def _gauss_newton_step(J: np.ndarray, r: np.ndarray, fixed=None) -> np.ndarray:
    """Gauss-Newton step restricted to the directions the data determine.

    ``J^T J`` is scaled to unit diagonal; directions whose curvature is below 1e-12 of
    the largest (unidentifiable combinations) get no step, nor do the coordinates in
    ``fixed`` (held at a bound).
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
    keep = w > _NULL * max(float(w.max()), 1e-300)
    inv = (V[:, keep] / w[keep]) @ V[:, keep].T
    delta[free] = -(inv @ (g / d)) / d
    return delta


def _offset(run: _Run, n_res: int, lo=None, hi=None) -> float:
    """Squared length of the Gauss-Newton step in units of the standard errors.

    ``delta^T J^T J delta / s^2``: how far the optimiser still expects to move,
    measured against the statistical uncertainty (Bates and Watts' relative offset).
    Coordinates on a bound that the step would push further out are held there.
    """
    J = run.J
    fixed = None
    if lo is not None:
        g = J.T @ run.r  # gradient of the cost; the step goes along -g
        tol = 1e-9 * np.maximum(1.0, np.abs(run.z))
        fixed = ((run.z <= lo + tol) & (g > 0)) | ((run.z >= hi - tol) & (g < 0))
    delta = _gauss_newton_step(J, run.r, fixed)
    s2 = 2.0 * run.cost / max(n_res - J.shape[1], 1)
    Jd = J @ delta
    return float(Jd @ Jd) / max(s2, 1e-300)


def _levenberg_marquardt(  # noqa: C901, PLR0915
    prob: _Problem,
    runs: list[_Run],
    n_sub: int,
    max_iter: int,
    tol: float,
    rtol: float,
    jacobian: str,
    desc: str,
    show_progress: bool | None,
) -> None:
    """Batched Levenberg-Marquardt over ``runs`` (updated in place).

    Every iteration simulates, in one numpy batch, three trial steps of each active run
    (damping lambda / 10, lambda, 10 lambda, Marquardt-scaled), each with its
    finite-difference perturbations when ``jacobian="fd"``, so that whichever step is
    accepted comes with its Jacobian: one batched simulation per iteration. A run stops
    when its Gauss-Newton step is shorter than ``sqrt(tol)`` standard errors
    (converged), when the cost decreases by less than ``rtol`` twice in a row, or after
    ``max_iter`` iterations.
    """
    p = prob.p
    n_res = prob.n_res
    per = 1 + 2 * p if jacobian == "fd" else 1  # simulated points per trial

    def jac_autograd(run: _Run) -> None:
        r, J = prob.autograd_jacobian(run.z, run.y0, n_sub)
        run.r = np.where(np.isfinite(r), r, np.nan)
        run.cost = _cost(run.r)
        run.J = np.where(np.isfinite(J), J, 0.0)

    def check(run: _Run, old: float) -> None:
        run.history.append(run.cost)
        run.offset = _offset(run, n_res, prob.lo, prob.hi)
        rel = (old - run.cost) / max(abs(old), 1e-300) if math.isfinite(old) else 1.0
        run.small = run.small + 1 if rel < rtol else 0
        if run.offset < tol:
            run.done = run.converged = True
        elif run.small >= 2:
            run.done = True
            run.converged = rtol > 1e-12  # a search stage: stalled is good enough

    for _ in progress(range(max_iter + 1), desc=desc, enable=show_progress):
        active = [r for r in runs if not r.done]
        if not active:
            return
        pts: list[np.ndarray] = []
        y0s: list[np.ndarray] = []
        plan = []
        for run in active:
            if run.J is None:  # first visit: residuals and Jacobian at the start
                if jacobian == "autograd":
                    jac_autograd(run)
                    plan.append((run, None, None))
                    continue
                fd, plus, minus = prob.fd_points(run.z)
                plan.append((run, None, [(run.z, plus, minus, len(pts))]))
                pts.extend(fd)
                y0s.extend([run.y0] * len(fd))
                continue
            if run.n_iter >= max_iter:
                run.done = True
                continue
            A = run.J.T @ run.J
            g = run.J.T @ run.r
            D = np.clip(np.diag(A), 1e-12 * max(float(np.max(np.diag(A))), 1e-300), None)
            lams = (0.1 * run.lam, run.lam, 10.0 * run.lam)
            trials = []
            for lam in lams:
                zt = np.clip(run.z + _solve(A + lam * np.diag(D), -g), prob.lo, prob.hi)
                if jacobian == "fd":
                    fd, plus, minus = prob.fd_points(zt)
                else:
                    fd, plus, minus = zt[None], None, None
                trials.append((zt, plus, minus, len(pts)))
                pts.extend(fd)
                y0s.extend([run.y0] * len(fd))
            plan.append((run, lams, trials))
        R = None
        if pts:
            Y = prob.predict(np.array(pts), np.array(y0s), n_sub)
            R = prob.residuals(Y)
        for run, lams, trials in plan:
            if lams is None:
                if trials is not None:
                    _, plus, minus, i0 = trials[0]
                    run.r = R[i0]
                    run.cost = _cost(run.r)
                    run.J = prob.fd_jacobian(R[i0 : i0 + per], plus, minus)
                if not math.isfinite(run.cost):
                    run.done = True
                    continue
                check(run, math.inf)
                continue
            run.n_iter += 1
            costs = [_cost(R[t[3]]) for t in trials]
            best = int(np.argmin(costs))
            old = run.cost
            if not costs[best] < old:
                run.lam = 100.0 * run.lam
                if run.lam > 1e12:
                    run.done = True
                continue
            zt, plus, minus, i0 = trials[best]
            run.z, run.r, run.cost = zt, R[i0], costs[best]
            if jacobian == "fd":
                run.J = prob.fd_jacobian(R[i0 : i0 + per], plus, minus)
            else:
                jac_autograd(run)
            run.lam = min(max(lams[best], 1e-12), 1e12)
            check(run, old)


# ---------------------------------------------------------------------------- inputs
def _check_free(free, known: PneumaticParams) -> list[str]:
    if isinstance(free, str):
        free = (free,)
    names = [f.name for f in dataclasses.fields(PneumaticParams)]
    out: list[str] = []
    for k in free:
        if not isinstance(k, str) or k not in names:
            raise ModelError(
                f"estimate_parameters: free parameter {k!r} is not a PneumaticParams "
                f"field{did_you_mean(k, names)} Choose from the fields of "
                "PneumaticParams (see PneumaticParams.describe())."
            )
        if k in _SENSOR_ONLY:
            raise ModelError(
                f"estimate_parameters: free parameter {k!r} only shapes sensor readings "
                f"that cannot be fitted here; the fittable signals are "
                f"{', '.join(FITTABLE_SIGNALS)}. Leave {k!r} in `known`."
            )
        if k in _TIMING:
            raise ModelError(
                f"estimate_parameters: free parameter {k!r} moves the valve switching "
                "instants, which a fixed-step simulation cannot differentiate; set it in "
                "`known` (read it off the recorded valve command)."
            )
        if k in out:
            raise ModelError(
                f"estimate_parameters: free parameter {k!r} is listed twice in `free`."
            )
        out.append(k)
    if not out:
        raise ModelError("estimate_parameters: `free` is empty; name at least one field.")
    return out


def _check_bounds(names: list[str], known: PneumaticParams, bounds) -> tuple:
    fields = {f.name: f for f in dataclasses.fields(PneumaticParams)}
    bounds = dict(bounds or {})
    for k in bounds:
        if k not in names:
            raise ModelError(
                f"estimate_parameters: bounds given for {k!r}, which is not in `free` "
                f"({', '.join(names)}); free it or drop its bounds."
            )
    log, lo, hi, th_lo, th_hi = [], [], [], [], []
    for k in names:
        meta = fields[k].metadata
        value = float(getattr(known, k))
        f_lo = meta["lo"] if meta["lo"] is not None else -math.inf
        f_hi = meta["hi"] if meta["hi"] is not None else math.inf
        if k in bounds:
            try:
                b_lo, b_hi = (float(b) for b in bounds[k])
            except (TypeError, ValueError) as exc:
                raise ModelError(
                    f"estimate_parameters: bounds[{k!r}] must be a pair (low, high); got "
                    f"{bounds[k]!r}."
                ) from exc
            if not b_lo < b_hi:
                raise ModelError(
                    f"estimate_parameters: bounds[{k!r}] = ({b_lo:g}, {b_hi:g}) must have "
                    "low < high."
                )
            if b_lo < f_lo or b_hi > f_hi or (meta["lo_open"] and b_lo <= f_lo):
                raise ModelError(
                    f"estimate_parameters: bounds[{k!r}] = ({b_lo:g}, {b_hi:g}) leave the "
                    f"allowed range [{f_lo:g}, {f_hi:g}] {meta['unit']} of {k}."
                )
        else:
            if value == 0.0 or not math.isfinite(f_lo):
                raise ModelError(
                    f"estimate_parameters: give bounds for {k!r} (known value {value:g}, "
                    f"range [{f_lo:g}, {f_hi:g}] {meta['unit']}): its range is open and "
                    "the known value gives no scale, e.g. bounds={"
                    f"{k!r}: (low, high)}}."
                )
            b_lo = max(f_lo, abs(value) / 100.0) if f_lo >= 0 else value - abs(value)
            b_hi = min(f_hi, abs(value) * 100.0) if f_lo >= 0 else value + abs(value)
        positive = b_lo > 0
        th_lo.append(b_lo)
        th_hi.append(b_hi)
        log.append(positive)
        lo.append(math.log(b_lo) if positive else b_lo)
        hi.append(math.log(b_hi) if positive else b_hi)
    return (
        np.array(log, dtype=bool),
        np.array(lo),
        np.array(hi),
        np.array(th_lo),
        np.array(th_hi),
    )


def _check_recording(recording, signals: list[str], member: int):  # noqa: C901
    """-> (fs, {signal: 1-D float array}, {other signal: array} for windowing)."""
    if isinstance(recording, ResponseData):
        n = recording.n_members
        if not -n <= member < n:
            raise DataError(
                f"estimate_parameters: member {member} out of range; the recording has "
                f"{n} members (0..{n - 1})."
            )
        if recording.time.size > 0 and abs(float(recording.time[0])) > 1e-12:
            raise DataError(
                "estimate_parameters: the recording must start at t = 0 of the valve "
                f"command schedule in `known`; its time starts at {recording.time[0]:g} s."
            )
        fs = recording.fs
        pool = {k: np.asarray(v)[member] for k, v in recording.outputs.items()}
        where = "recording.outputs"
    elif isinstance(recording, Mapping):
        if "fs" not in recording:
            raise DataError(
                "estimate_parameters: the recording mapping has no 'fs' entry; add the "
                "sampling rate in Hz, e.g. {'fs': 1000.0, 'LeverPosition': x, ...}."
            )
        fs = recording["fs"]
        pool = {k: v for k, v in recording.items() if k != "fs"}
        where = "the recording"
    else:
        raise DataError(
            "estimate_parameters: recording must be a mapping of signal name -> 1-D "
            "array with an 'fs' entry, or a PneumaticResponse; got "
            f"{type(recording).__name__}."
        )
    try:
        fs = float(fs)
    except (TypeError, ValueError) as exc:
        raise DataError(f"estimate_parameters: fs must be a number; got {fs!r}.") from exc
    if not (math.isfinite(fs) and fs > 0):
        raise DataError(f"estimate_parameters: fs must be positive and finite; got {fs}.")
    data = {}
    n = None
    for s in [*signals, *(k for k in ("LeverPosition",) if k not in signals)]:
        if s not in pool:
            if s not in signals:
                continue
            raise DataError(
                f"estimate_parameters: signal {s!r} is missing from {where}"
                f"{did_you_mean(s, pool)} It has "
                f"{', '.join(map(str, pool)) or 'no signals'}. Record it or drop it from "
                "`signals`."
            )
        try:
            arr = np.asarray(pool[s], dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise DataError(
                f"estimate_parameters: signal {s!r} must be numeric; got "
                f"{type(pool[s]).__name__}."
            ) from exc
        if arr.ndim != 1:
            raise DataError(
                f"estimate_parameters: signal {s!r} must be 1-D (one member's samples); "
                f"got shape {arr.shape}. Pass one member (`member=`) of a batch."
            )
        bad = ~np.isfinite(arr)
        if bad.any():
            if s not in signals:
                continue
            raise DataError(
                f"estimate_parameters: signal {s!r} has {int(bad.sum())} non-finite "
                f"samples (first at index {int(np.flatnonzero(bad)[0])}); fill or "
                "interpolate the gaps (dropouts) or drop the signal."
            )
        if n is None:
            n = arr.size
        elif arr.size != n:
            raise DataError(
                f"estimate_parameters: signal {s!r} has {arr.size} samples, the others "
                f"{n}; all signals must share one time base at fs = {fs:g} Hz."
            )
        data[s] = arr
    return fs, data, n


def _noise_scale(x: np.ndarray) -> float:
    """Robust white-noise std from second differences, floored at 1e-3 of the range."""
    d2 = np.diff(x, 2)
    mad = float(np.median(np.abs(d2 - np.median(d2)))) * 1.4826 / math.sqrt(6.0)
    span = float(np.ptp(x))
    return max(mad, 1e-3 * span, 1e-12)


def _windows(
    known: PneumaticParams,
    fs: float,
    n: int,
    data: Mapping[str, np.ndarray],
    window,
    max_windows: int | None,
) -> tuple[np.ndarray, int]:
    """First samples of the windows and their common length (samples)."""
    switches = [t for t in _switch_times(known, n / fs) if t * fs < n - 2]
    if not switches:
        raise DataError(
            f"estimate_parameters: the recording ({n / fs:g} s) holds no switch of the "
            f"valve command of `known` (first at {known.cycle_start + known.valve_delay:g}"
            f" s, period {known.cycle_period:g} s); the windows start at those switches."
        )
    k_sw = np.array([math.floor(t * fs + 1e-6) for t in switches])
    ends = np.append(k_sw[1:], n)  # a window never crosses the next switch
    if max_windows is not None:
        if not isinstance(max_windows, int | np.integer) or max_windows < 1:
            raise ModelError(
                f"estimate_parameters: max_windows must be a positive integer or None; "
                f"got {max_windows!r}."
            )
        k_sw, ends = k_sw[: int(max_windows)], ends[: int(max_windows)]
    k0 = np.maximum(k_sw - round(_PRE_SWITCH * fs), 0)
    room = int(np.min(ends - k0))
    if isinstance(window, str):
        if window != "auto":
            raise ModelError(
                f"estimate_parameters: window must be 'auto' or a length in s; got "
                f"{window!r}."
            )
        if "LeverPosition" in data:
            x = data["LeverPosition"]
        else:
            r = simulate_piston(known, t_end=n / fs, fs=fs, sensors=False, progress=False)
            x = np.asarray(r.states["position"][0])
        need = 0
        for a, b, first in zip(k_sw, ends, k0, strict=True):
            seg = x[a:b]
            rest = float(np.median(seg[-max(1, seg.size // 5) :]))
            moving = np.flatnonzero(np.abs(seg - rest) > _SETTLE_TOL)
            arrive = (int(moving[-1]) + 1) if moving.size else 0
            need = max(need, int(a - first) + arrive)
        length = min(room, need + round(_MARGIN * fs))
    else:
        try:
            w = float(window)
        except (TypeError, ValueError) as exc:
            raise ModelError(
                f"estimate_parameters: window must be 'auto' or a length in s; got "
                f"{window!r}."
            ) from exc
        if not (math.isfinite(w) and w > 0):
            raise ModelError(f"estimate_parameters: window must be > 0 s; got {w}.")
        length = round(w * fs)
        if length > room:
            raise ModelError(
                f"estimate_parameters: window = {w:g} s is longer than the {room / fs:g} s "
                "between a window start and the next switch (or the end of the "
                "recording); shorten it."
            )
    if length < 3:
        raise ModelError(
            f"estimate_parameters: windows of {length} samples are too short to fit; "
            "use a longer window."
        )
    return k0, int(length)


def _latin_hypercube(rng: np.random.Generator, n: int, p: int) -> np.ndarray:
    cut = (np.arange(n)[:, None] + rng.random((n, p))) / n
    for j in range(p):
        cut[:, j] = cut[rng.permutation(n), j]
    return cut


# ---------------------------------------------------------------------------- result
@dataclasses.dataclass(eq=False, repr=False)
class EstimationResult:
    """Estimated parameters with their uncertainty, and the fitted windows.

    Attributes
    ----------
    params : PneumaticParams
        ``known`` with the free parameters replaced by their estimates.
    estimates, stderr : dict of str to float
        Estimate and standard error of each free parameter (inf: unidentifiable).
    ci95 : dict of str to tuple of float
        95 % confidence interval of each free parameter (in log space for positive
        parameters, so it stays positive and is asymmetric).
    correlation : pandas.DataFrame
        Correlation of the estimates (of their logarithms for positive parameters).
    converged : bool
        Whether the refinement ended within half a standard error of the optimum (its
        remaining Gauss-Newton step; a ConvergenceWarning said otherwise).
    cost : float
        Half the sum of squared weighted residuals at the estimate.
    cost_history : list of float
        The cost after each accepted step, coarse stage then fine stage (the fine stage
        restarts whenever the weights are re-estimated).
    starts : pandas.DataFrame
        Each start of the coarse stage: its first point, where it ended and the cost.
    sigma : dict of str to float
        Residual scale of each signal used as its weight (its unit).
    rmse : dict of str to float
        RMS residual of each signal at the estimate (its unit).
    windows : ndarray, shape (n_windows, 2)
        Time (s) of the first and last fitted sample of each window.
    time : ndarray, shape (n_windows, n_samples)
        Times of the fitted samples.
    measured, fitted : dict of str to ndarray, shape (n_windows, n_samples)
        Measured and fitted readings of each signal at those times.
    known, bounds, units : dict
        Per free parameter: the value in ``known`` (the first start), the bounds and
        the unit.
    n_iter : int
        Iterations of the refinement.
    offset : float
        Squared length of the last Gauss-Newton step in standard errors.
    jacobian : ndarray, shape (n_residuals, n_free)
        Jacobian of the weighted residuals in the optimised (log) coordinates.
    elapsed : float
        Wall time of the fit in s.

    Examples
    --------
    >>> from pdmkit.models import EstimationResult
    >>> r = EstimationResult(estimates={"c_a_in": 5e-6}, stderr={"c_a_in": 1e-8})
    >>> r.estimates["c_a_in"], r.converged
    (5e-06, False)
    """

    params: Any = None
    estimates: dict = dataclasses.field(default_factory=dict)
    stderr: dict = dataclasses.field(default_factory=dict)
    ci95: dict = dataclasses.field(default_factory=dict)
    correlation: Any = None
    converged: bool = False
    cost: float = math.nan
    cost_history: list = dataclasses.field(default_factory=list)
    starts: Any = None
    sigma: dict = dataclasses.field(default_factory=dict)
    rmse: dict = dataclasses.field(default_factory=dict)
    windows: Any = None
    time: Any = None
    measured: dict = dataclasses.field(default_factory=dict)
    fitted: dict = dataclasses.field(default_factory=dict)
    known: dict = dataclasses.field(default_factory=dict)
    bounds: dict = dataclasses.field(default_factory=dict)
    units: dict = dataclasses.field(default_factory=dict)
    n_iter: int = 0
    offset: float = math.nan
    jacobian: Any = None
    elapsed: float = math.nan

    def __repr__(self) -> str:
        parts = ", ".join(
            f"{k}={v:.4g} (+-{self.stderr.get(k, math.nan):.2g})"
            for k, v in self.estimates.items()
        )
        flag = "converged" if self.converged else "NOT converged"
        return f"<EstimationResult {flag}: {parts}>"

    def to_pandas(self):
        """One row per free parameter: estimate, stderr, CI, bounds, identifiability.

        Columns: ``estimate``, ``stderr``, ``ci95_low``, ``ci95_high``,
        ``rel_halfwidth`` (half the CI width over the estimate), ``known`` (the value in
        ``known``, the first start), ``lower``/``upper`` (bounds), ``at_bound``,
        ``identifiable`` (finite CI narrower than +-50 %) and ``unit``.

        Returns
        -------
        pandas.DataFrame

        Examples
        --------
        >>> from pdmkit.models import EstimationResult
        >>> r = EstimationResult(estimates={"c_a_in": 5e-6}, stderr={"c_a_in": 1e-8},
        ...     ci95={"c_a_in": (4.98e-6, 5.02e-6)}, known={"c_a_in": 5e-6},
        ...     bounds={"c_a_in": (5e-8, 5e-4)}, units={"c_a_in": "m^2"})
        >>> row = r.to_pandas().loc["c_a_in"]
        >>> float(row["rel_halfwidth"]), bool(row["identifiable"])
        (0.004, True)
        """
        import pandas as pd

        rows = []
        for k, est in self.estimates.items():
            lo, hi = self.ci95[k]
            lb, ub = self.bounds[k]
            half = 0.5 * (hi - lo) / abs(est) if est != 0 else math.inf
            rows.append(
                {
                    "parameter": k,
                    "estimate": est,
                    "stderr": self.stderr[k],
                    "ci95_low": lo,
                    "ci95_high": hi,
                    "rel_halfwidth": round(half, 12),
                    "known": self.known[k],
                    "lower": lb,
                    "upper": ub,
                    "at_bound": bool(
                        np.isclose(est, lb, rtol=1e-6) or np.isclose(est, ub, rtol=1e-6)
                    ),
                    "identifiable": bool(math.isfinite(half) and half < 0.5),
                    "unit": self.units[k],
                }
            )
        return pd.DataFrame(rows).set_index("parameter")

    def plot(self, ax=None, signals: Sequence[str] | None = None):
        """Measured against fitted readings over the windows (matplotlib imported here).

        Parameters
        ----------
        ax : matplotlib Axes or sequence of Axes, optional
            One axes per signal; None: a new figure with one row per signal.
        signals : sequence of str, optional
            Which fitted signals (default: all).

        Returns
        -------
        numpy.ndarray of Axes

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models import EstimationResult
        >>> t = np.arange(6.0).reshape(2, 3) / 1e3
        >>> r = EstimationResult(time=t, measured={"LeverPosition": t * 0.1},
        ...     fitted={"LeverPosition": t * 0.1}, units={})
        >>> r.plot().shape
        (1,)
        """
        import matplotlib.pyplot as plt

        signals = list(signals) if signals is not None else list(self.measured)
        for s in signals:
            if s not in self.measured:
                raise ModelError(
                    f"plot: {s!r} was not fitted; choose from {', '.join(self.measured)}."
                )
        if ax is None:
            _, axes = plt.subplots(
                len(signals), 1, sharex=True, squeeze=False, figsize=(8, 2 * len(signals))
            )
            axes = axes[:, 0]
        else:
            axes = np.atleast_1d(np.asarray(ax, dtype=object)).ravel()
            if axes.size != len(signals):
                raise ModelError(
                    f"plot: got {axes.size} axes for {len(signals)} signals; pass one "
                    "axes per signal or None."
                )
        gap = np.full((self.time.shape[0], 1), np.nan)
        t = np.concatenate([self.time, gap], axis=1).ravel()
        for a, s in zip(axes, signals, strict=True):
            m = np.concatenate([self.measured[s], gap], axis=1).ravel()
            f = np.concatenate([self.fitted[s], gap], axis=1).ravel()
            a.plot(t, m, ".", ms=2, color="0.5", label="measured")
            a.plot(t, f, lw=1.0, color="C3", label="fitted")
            unit = SENSOR_UNITS.get(s, "")
            a.set_ylabel(f"{s}\n[{unit}]" if unit else s)
        axes[0].legend(loc="best", fontsize="small")
        axes[-1].set_xlabel("time [s]")
        return axes


def _covariance(J: np.ndarray, cost: float, p: int):
    """Covariance of the optimised coordinates; inf where unidentifiable."""
    n = J.shape[0]
    s2 = 2.0 * cost / max(n - p, 1)
    A = J.T @ J
    d = np.sqrt(np.diag(A))
    cov = np.full((p, p), np.nan)
    dead = d <= 1e-300
    live = ~dead
    if live.any():
        Al = A[np.ix_(live, live)] / np.outer(d[live], d[live])
        w, V = np.linalg.eigh(Al)
        null = w < _NULL * max(float(w.max()), 1e-300)
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


def _setup_problem(
    recording,
    free,
    known,
    signals,
    bounds,
    window,
    max_windows,
    member,
    dt,
) -> tuple[_Problem, dict]:
    """Validate the inputs and build the fit (no optimisation yet)."""
    if known is None:
        known = PneumaticParams()
    if not isinstance(known, PneumaticParams):
        raise ModelError(
            f"estimate_parameters: known must be a PneumaticParams; got "
            f"{type(known).__name__}."
        )
    if known.n_members is not None or known.is_torch:
        raise ModelError(
            "estimate_parameters: known must hold one scalar value per parameter (numpy "
            f"floats); got a batch of {known.n_members} members or torch tensors. Use "
            "known.member(i)."
        )
    names = _check_free(free, known)
    if isinstance(signals, str):
        signals = (signals,)
    signals = list(signals)
    if not signals:
        raise ModelError("estimate_parameters: `signals` is empty; name a sensor to fit.")
    for s in signals:
        if s not in FITTABLE_SIGNALS:
            raise ModelError(
                f"estimate_parameters: cannot fit signal {s!r}"
                f"{did_you_mean(s, FITTABLE_SIGNALS)} Fittable signals: "
                f"{', '.join(FITTABLE_SIGNALS)}."
            )
    if len(set(signals)) != len(signals):
        raise ModelError(f"estimate_parameters: `signals` repeats a name: {signals}.")
    log, lo, hi, th_lo, th_hi = _check_bounds(names, known, bounds)
    fs, data, n = _check_recording(recording, signals, member)
    if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
        raise ModelError(f"estimate_parameters: dt must be a positive number; got {dt!r}.")
    sub = 1.0 / (fs * dt)
    n_sub = round(sub)
    if n_sub < 1 or abs(sub - n_sub) > 1e-6 * sub:
        raise ModelError(
            f"estimate_parameters: 1/fs = {1 / fs:g} s must be a whole number of steps "
            f"dt = {dt:g} s; choose dt = 1/(fs k), e.g. {1 / (fs * max(1, round(sub))):g}."
        )
    n_sub_c = max(1, min(n_sub, round(1.0 / (fs * _COARSE_DT))))
    k0, length = _windows(known, fs, n, data, window, max_windows)
    idx = k0[:, None] + np.arange(length)[None, :]
    meas = np.stack([data[s][idx] for s in signals])  # (S, W, L)
    sigma = np.array([_noise_scale(data[s]) for s in signals])
    prob = _Problem(
        known=known,
        names=names,
        log=log,
        lo=lo,
        hi=hi,
        th_lo=th_lo,
        th_hi=th_hi,
        signals=signals,
        fs=fs,
        k0=k0,
        length=length,
        meas=meas,
        sigma=sigma,
        h_fine=1.0 / (fs * n_sub),
        n_sub_fine=n_sub,
        n_sub_coarse=n_sub_c,
    )
    return prob, data


# ---------------------------------------------------------------------------- public
def estimate_parameters(  # noqa: PLR0915
    recording,
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
    seed=0,
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
    if jacobian not in ("fd", "autograd"):
        raise ModelError(
            f"estimate_parameters: jacobian must be 'fd' or 'autograd'; got {jacobian!r}."
        )
    if not isinstance(n_starts, int | np.integer) or n_starts < 1:
        raise ModelError(
            f"estimate_parameters: n_starts must be a positive integer; got {n_starts!r}."
        )
    if not isinstance(max_iter, int | np.integer) or max_iter < 1:
        raise ModelError(
            f"estimate_parameters: max_iter must be a positive integer; got {max_iter!r}."
        )
    prob, data = _setup_problem(
        recording, free, known, signals, bounds, window, max_windows, member, dt
    )
    known, names, signals, fs = prob.known, prob.names, prob.signals, prob.fs
    log, lo, hi, th_lo, th_hi = prob.log, prob.lo, prob.hi, prob.th_lo, prob.th_hi
    n_sub, n_sub_c = prob.n_sub_fine, prob.n_sub_coarse
    k0, length, meas, W = prob.k0, prob.length, prob.meas, prob.n_windows
    p = prob.p
    # ---- starts: the known values, then a Latin hypercube within half a decade
    z_known = prob.encode(np.array([float(getattr(known, k)) for k in names]))
    half_decade = np.where(log, math.log(10.0) / 2.0, np.inf)
    s_lo = np.maximum(lo, z_known - half_decade)
    s_hi = np.minimum(hi, z_known + half_decade)
    s_lo = np.where(np.isfinite(s_lo), s_lo, lo)
    s_hi = np.where(np.isfinite(s_hi), s_hi, hi)
    rng = np.random.default_rng(seed)
    Z0 = np.empty((n_starts, p))
    Z0[0] = z_known
    if n_starts > 1:
        Z0[1:] = s_lo + _latin_hypercube(rng, n_starts - 1, p) * (s_hi - s_lo)
    Y0 = prob.window_states(Z0)
    runs = [_Run(z=Z0[i].copy(), y0=Y0[i]) for i in range(n_starts)]
    # ---- stage 1: every start at the coarse step
    # the coarse model differs from the data by its step error anyway: stop once the
    # cost stalls (relative decrease below 1e-4 twice) or the step is within one SE
    _levenberg_marquardt(
        prob,
        runs,
        n_sub_c,
        min(max_iter, _COARSE_ITER),
        1.0,
        1e-4,
        "fd",
        "estimate (coarse)",
        progress,
    )
    best = min(runs, key=lambda r: r.cost)
    if not math.isfinite(best.cost):
        raise ModelError(
            "estimate_parameters: every start failed to simulate (non-finite readings); "
            "check `known` and narrow the bounds."
        )
    history = list(best.history)
    # ---- stage 2: refine the best start at the integrator's step, re-estimating the
    # weights (sigma) from the residuals until they settle
    z = best.z.copy()
    y0 = prob.window_states(z[None])[0]
    fine = _Run(z=z, y0=y0, lam=1e-4)
    block = W * (length - 1)  # residuals per signal
    for rnd in range(4):
        # the weights move after the first round: converge loosely until they settle
        tol = 1e-4 if rnd > 0 else 1.0
        if fine.J is not None:
            fine.offset = _offset(fine, prob.n_res, lo, hi)
            fine.done = fine.converged = fine.offset < tol
        _levenberg_marquardt(
            prob,
            [fine],
            n_sub,
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
            z=fine.z,
            y0=y0,
            lam=fine.lam,
            r=fine.r * rows,
            J=fine.J * rows[:, None],
            n_iter=fine.n_iter,
        )
        fine.cost = _cost(fine.r)
        if rnd > 0 and np.all((ratio > 1 / 1.2) & (ratio < 1.2)):
            break
    z = fine.z
    # the residuals and Jacobian at the estimate, weighted by the final sigma
    r_fin, J, cost = fine.r, fine.J, fine.cost
    offset = _offset(fine, prob.n_res, lo, hi)
    # the refinement aims at 0.01 standard error; where the fixed-step map is too rough
    # for that (impacts, contacts switching within a step) it stalls a little short:
    # half a standard error still counts (it adds at most ~12 % to the error's spread)
    converged = offset < _CONVERGED
    if not converged:
        cov, _ = _covariance(J, cost, p)
        blind = [k for j, k in enumerate(names) if not np.isfinite(cov[j, j])]
        hint = (
            f" {', '.join(blind)} cannot be determined from {', '.join(signals)}: fix "
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
            stacklevel=2,
        )
    fitted_Y = (
        meas[..., 1:]
        + r_fin.reshape(len(signals), W, length - 1) * (prob.sigma[:, None, None])
    )
    cov, _ = _covariance(J, cost, p)
    from scipy import stats

    tq = float(stats.t.ppf(0.975, max(prob.n_res - p, 1)))
    theta = prob.theta(z)
    est, se, ci = {}, {}, {}
    for j, k in enumerate(names):
        sz = math.sqrt(cov[j, j]) if np.isfinite(cov[j, j]) else math.inf
        v = float(theta[j])
        est[k] = v
        if log[j]:
            se[k] = v * sz if math.isfinite(sz) else math.inf
            spread = math.exp(min(tq * sz, 700.0))  # inf-safe: an unidentifiable
            ci[k] = (v / spread, v * spread) if spread < 1e300 else (0.0, math.inf)
        else:
            se[k] = sz
            ci[k] = (v - tq * sz, v + tq * sz)
    import pandas as pd

    sd = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    correlation = pd.DataFrame(corr, index=names, columns=names)
    start_rows = []
    for i, run in enumerate(runs):
        row = {"start": i, "cost": run.cost, "iterations": run.n_iter}
        th0 = prob.theta(Z0[i])
        th1 = prob.theta(run.z)
        for j, k in enumerate(names):
            row[f"{k} (start)"] = float(th0[j])
            row[k] = float(th1[j])
        start_rows.append(row)
    starts = pd.DataFrame(start_rows).set_index("start")
    t_win = (k0[:, None] + np.arange(1, length)[None, :]) / fs
    fitted = {s: fitted_Y[i] for i, s in enumerate(signals)}
    measured = {s: meas[i, :, 1:] for i, s in enumerate(signals)}
    rmse = {s: float(np.sqrt(np.mean((fitted[s] - measured[s]) ** 2))) for s in signals}
    fields = {f.name: f for f in dataclasses.fields(PneumaticParams)}
    return EstimationResult(
        params=prob.params_of(z),
        estimates=est,
        stderr=se,
        ci95=ci,
        correlation=correlation,
        converged=bool(converged),
        cost=cost,
        cost_history=history,
        starts=starts,
        sigma={s: float(v) for s, v in zip(signals, prob.sigma, strict=True)},
        rmse=rmse,
        windows=np.stack([t_win[:, 0], t_win[:, -1]], axis=1),
        time=t_win,
        measured=measured,
        fitted=fitted,
        known={k: float(getattr(known, k)) for k in names},
        bounds={k: (float(th_lo[j]), float(th_hi[j])) for j, k in enumerate(names)},
        units={k: fields[k].metadata["unit"] for k in names},
        n_iter=fine.n_iter,
        offset=offset,
        jacobian=J,
        elapsed=_time.perf_counter() - t_start,
    )
