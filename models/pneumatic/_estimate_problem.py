"""The estimation problem of the pneumatic twin: windows, batched simulation, residuals.

:class:`_Problem` holds what :func:`~pdmkit.models.pneumatic.estimate_parameters` fits
(free parameters in their optimised space and bounds, the windows and the measured
readings) and simulates the windows of many parameter vectors in one numpy batch with
the twin's fixed-step integrator (:func:`_run_windows`), or through torch for autograd
Jacobians. :class:`_WindowFit` hands that to the shared batched Levenberg-Marquardt of
:mod:`pdmkit.models._optim`.
"""

from __future__ import annotations

import dataclasses
import types
from collections.abc import Sequence

import numpy as np

from pdmkit._optional import require
from pdmkit._progress import progress
from pdmkit.errors import ModelError
from pdmkit.models._optim import (
    Evaluation,
    LMOptions,
    LMRun,
    Trial,
    levenberg_marquardt,
)
from pdmkit.models._xp import TorchNamespace, get_namespace
from pdmkit.models.pneumatic._integrate import (
    event_step,
    simulate_piston,
    step_coefficients,
)
from pdmkit.models.pneumatic._sensors import P_STD, T_STD
from pdmkit.models.pneumatic._twin import PneumaticParams, _command, _resolve

_RHO_STD = P_STD / (287.1 * T_STD)  # as the flow sensors of _sensors.ideal_readings
_TO_LPM = 60000.0 / _RHO_STD
_FD_STEP = 1e-5  # central-difference step in the transformed (log) parameters


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
    trapezoidal mechanics, sub-steps at contact events: ``event_step``); ``u_table``
    (n_steps, n) holds the delayed command. Returns
    position, velocity, supply pressure (at the samples) and the valve mass flow into A
    (mean over each sample interval; 0 at the first sample), each (n, n_samples).
    """
    r = _resolve(params, xp)
    coefs = step_coefficients(r, h, xp)
    x, v, pa, pb, pr, s = (y0[:, i] for i in range(6))
    u_all = xp.asarray(u_table)
    zero = 0.0 * x
    rec_x, rec_v, rec_pr, rec_ma = [x], [v], [pr], [zero]
    inv = 1.0 / n_sub
    step = 0
    for _ in range(1, n_samples):
        s_ma = zero
        for _j in range(n_sub):
            (x, v, pa, pb, pr, s), d = event_step(
                0.0, (x, v, pa, pb, pr, s), u_all[step], r, h, coefs, xp
            )
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
        torch = require("torch", what="estimate_parameters(jacobian='autograd')")

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
class _Run(LMRun):
    """One start of the batched Levenberg-Marquardt, with its windows' start states."""

    y0: np.ndarray | None = None  # (W, 6) window start states


class _WindowFit:
    """:class:`_Problem` at one step and Jacobian source, as the shared LM asks it.

    ``jacobian="fd"``: every trial point comes with its central-difference points in
    the same numpy batch; ``"autograd"``: trials are simulated alone and the Jacobian is
    taken by torch where it is asked for.
    """

    def __init__(self, prob: _Problem, n_sub: int, jacobian: str):
        self.prob, self.n_sub, self.jacobian = prob, n_sub, jacobian

    def bounds(self, run: _Run) -> tuple[np.ndarray, np.ndarray, None]:
        """The bounds of the optimised coordinates (the same for every start)."""
        return self.prob.lo, self.prob.hi, None

    def evaluate(self, trials: Sequence[Trial]) -> list[Evaluation]:
        """Residuals (and Jacobians where asked) of every trial: one numpy batch."""
        prob, fd = self.prob, self.jacobian == "fd"
        pts: list[np.ndarray] = []
        y0s: list[np.ndarray] = []
        plan: list = []
        for t in trials:
            if t.jacobian and not fd:
                r, J = prob.autograd_jacobian(t.theta, t.run.y0, self.n_sub)
                r = np.where(np.isfinite(r), r, np.nan)
                plan.append(Evaluation(r, np.where(np.isfinite(J), J, 0.0)))
                continue
            if t.jacobian:
                points, plus, minus = prob.fd_points(t.theta)
            else:
                points, plus, minus = t.theta[None], None, None
            plan.append((len(pts), plus, minus))
            pts.extend(points)
            y0s.extend([t.run.y0] * len(points))
        R = None
        if pts:
            R = prob.residuals(prob.predict(np.array(pts), np.array(y0s), self.n_sub))
        out = []
        for item in plan:
            if isinstance(item, Evaluation):
                out.append(item)
                continue
            i0, plus, minus = item
            if plus is None:
                out.append(Evaluation(R[i0]))
            else:
                J = prob.fd_jacobian(R[i0 : i0 + 1 + 2 * prob.p], plus, minus)
                out.append(Evaluation(R[i0], J))
        return out


def _levenberg_marquardt(
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
    accepted comes with its Jacobian: one batched simulation per iteration (with
    ``"autograd"`` the Jacobian is taken at the accepted step). A run stops when its
    Gauss-Newton step is shorter than ``sqrt(tol)`` standard errors (converged), when
    the cost decreases by less than ``rtol`` twice in a row, when lambda passes 1e12, or
    after ``max_iter`` iterations.
    """
    options = LMOptions(
        trials=(0.1, 1.0, 10.0),
        after_accept=((0.1, 1.0), (1.0, 1.0), (10.0, 1.0)),
        lam_min=1e-12,
        lam_max=1e12,
        after_reject=100.0,
        give_up=1e12,
        trial_jacobians=3 if jacobian == "fd" else 0,
        refresh_now=jacobian != "fd",
        ftol=rtol,
        offset_tol=tol,
        test_at_start=True,
    )
    levenberg_marquardt(
        _WindowFit(prob, n_sub, jacobian),
        runs,
        max_iter,
        options,
        ticks=lambda passes: progress(passes, desc=desc, enable=show_progress),
    )
