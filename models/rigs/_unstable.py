r"""An unstable, under-actuated plant under a known controller: the planar ballbot.

The S-Mobile identification paper studies the S-Mobile, a body balanced on a sphere
driven by omni-wheels, in closed loop: its dynamics ``M(q) q'' + C(q, q') q' + G(q) =
F(q) u`` (eq. 1) are linearised (eq. 2), stabilised by a known state feedback ``u = -K x
+ N w`` with a set-point filter (eq. 3), and the closed loop's tilt response ``theta /
theta_set`` is measured with chirps of 1.5 to 5 degrees through a 100 Hz CAN bus (sec.
4-5).

:class:`BallbotRig` is that plant in one plane (the ballbot of Fankhauser & Gwerder,
*Modeling and control of a ballbot*, ETH 2010, planar model): coordinates ``psi`` (ball
rotation) and ``theta`` (body tilt), the drive torque ``tau`` between ball and body,

.. math::

    \begin{bmatrix} M_{11} & c \cos\theta \\ c \cos\theta & \Theta_x \end{bmatrix}
    \begin{bmatrix} \ddot\psi \\ \ddot\theta \end{bmatrix} =
    \begin{bmatrix} \tau - F(\dot\psi - \dot\theta) - b_\psi \dot\psi
        + c \sin\theta\, \dot\theta^2 + d \\
        -\tau + F(\dot\psi - \dot\theta) + m_B g l \sin\theta \end{bmatrix}

with ``M11 = (m_b + m_B) r^2 + I_b``, ``c = m_B r l``, ``Theta_x`` the body's moment of
inertia about the ball centre (the parameter the paper identifies, 20.31), the drive
friction ``F(v) = b v + tau_c tanh(v / v_eps)`` (viscous and Coulomb: the source of the
amplitude dependence the paper sees at small excitations), a rolling resistance
``b_psi`` and a random floor torque ``d``. The drive is a first-order lag ``T_m`` with a
torque limit; the controller runs at 100 Hz and gets its measurements one CAN cycle
(10 ms) late. Upright, the plant has one unstable pole,
``sqrt(m_B g l M11 / (M11 Theta_x - c^2))``, which is ``sqrt(g / l)`` for a point body
on a ball that does not move.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from scipy import linalg, signal

from pdmkit.errors import DataError, ModelError
from pdmkit.models.ode import LinearModel

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["BallbotController", "BallbotRecord", "BallbotRig", "chirp_reference"]

STATES = ("psi", "theta", "psi_rate", "theta_rate")


@dataclass(frozen=True)
class BallbotController:
    """The known stabilising controller ``u[k] = -K x_meas[k - delay] + N w[k]``.

    Attributes
    ----------
    K : ndarray (4,)
        State-feedback gains on ``(psi, theta, psi_rate, theta_rate)`` (N m per rad,
        per rad/s).
    N : float
        Set-point filter: the tilt reference ``w`` (rad) enters as ``N w``; ``N = K[1]``
        makes ``u = -K (x - x_ref)`` with ``x_ref = (0, w, 0, 0)``.
    fs : float
        Controller rate (Hz).
    delay : int
        Samples between a measurement and its use (the CAN cycle).

    Examples
    --------
    >>> ctl = BallbotRig().controller()
    >>> ctl.fs, ctl.delay, bool(ctl.N == ctl.K[1])
    (100.0, 1, True)
    """

    K: np.ndarray
    N: float
    fs: float = 100.0
    delay: int = 1

    def to_pandas(self) -> pd.Series:
        """Gains by state, ``N``, ``fs`` and ``delay``."""
        return pd.Series(
            {
                **dict(zip(STATES, self.K, strict=True)),
                "N": self.N,
                "fs": self.fs,
                "delay": self.delay,
            }
        )


@dataclass(eq=False)
class BallbotRecord:
    """Closed-loop records of the ballbot, one row per run (excitation amplitude).

    Attributes
    ----------
    time : ndarray (n,)
    reference : ndarray (n_runs, n)
        Tilt set-point ``w`` (rad).
    command : ndarray (n_runs, n)
        Torque command ``u`` (N m) the controller sent.
    states : ndarray (n_runs, n, 4)
        Measured ``psi, theta, psi_rate, theta_rate`` (rad, rad/s).
    fs : float
    amplitudes_deg : ndarray (n_runs,)
        Reference amplitude of each run.
    saturated : ndarray (n_runs,)
        Share of samples at the torque limit.

    Examples
    --------
    >>> rig = BallbotRig()
    >>> rec = rig.simulate(chirp_reference([2.0], duration=2.0), seed=0)
    >>> rec.states.shape, rec.to_pandas().columns.tolist()[:4]
    ((1, 200, 4), ['run', 'time', 'reference', 'command'])
    """

    time: np.ndarray
    reference: np.ndarray
    command: np.ndarray
    states: np.ndarray
    fs: float
    amplitudes_deg: np.ndarray
    saturated: np.ndarray
    info: dict = field(default_factory=dict, repr=False)

    @property
    def theta(self) -> np.ndarray:
        """Measured tilt (rad), (n_runs, n)."""
        return self.states[..., 1]

    def to_pandas(self) -> pd.DataFrame:
        """Long table: ``run, time, reference, command`` and the four states."""
        frames = []
        for i in range(self.reference.shape[0]):
            data = {
                "run": i,
                "time": self.time,
                "reference": self.reference[i],
                "command": self.command[i],
            }
            data.update({s: self.states[i, :, j] for j, s in enumerate(STATES)})
            frames.append(pd.DataFrame(data))
        return pd.concat(frames, ignore_index=True)

    def plot(self, ax: Axes | None = None, run: int = 0) -> Axes:
        """Reference and measured tilt (degrees) of one run; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3))
        ax.plot(self.time, np.degrees(self.reference[run]), lw=0.8, label="theta_set")
        ax.plot(self.time, np.degrees(self.theta[run]), lw=0.8, label="theta")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("tilt [deg]")
        ax.legend(loc="upper right", fontsize="small")
        return ax


def chirp_reference(
    amplitudes_deg: ArrayLike,
    *,
    duration: float = 81.92,
    period: float = 20.48,
    f0: float = 0.2,
    f1: float = 25.0,
    fs: float = 100.0,
) -> np.ndarray:
    """Periodic logarithmic chirps of the tilt set-point, one row per amplitude (rad).

    The paper feeds chirps of 1.5 to 5 degrees as the reference (sec. 5); a periodic
    chirp of ``period`` seconds, repeated, gives one Welch segment per period.

    Examples
    --------
    >>> w = chirp_reference([1.5, 5.0], duration=20.48)
    >>> w.shape, round(float(np.degrees(w[1]).max()), 2)
    ((2, 2048), 5.0)
    """
    amps = np.radians(np.atleast_1d(np.asarray(amplitudes_deg, dtype=float)))
    n = round(duration * fs)
    t = (np.arange(n) % round(period * fs)) / fs
    wave = signal.chirp(t, f0, period, f1, method="logarithmic", phi=-90)
    return amps[:, None] * wave[None, :]


@dataclass(frozen=True)
class BallbotRig:
    """The planar ballbot (S-Mobile-like): parameters, physics, linearisation, control.

    Parameters
    ----------
    body_mass, com_height : float
        Body mass ``m_B`` (kg) and height ``l`` (m) of its centre of mass above the ball
        centre.
    body_inertia : float
        ``Theta_x``: the body's moment of inertia about the ball centre (kg m^2), the
        paper's identified parameter (20.31).
    ball_mass, ball_radius, ball_inertia : float
        The sphere (kg, m, kg m^2).
    drive_damping, drive_coulomb, coulomb_velocity : float
        Drive friction ``b`` (N m s/rad), ``tau_c`` (N m) and its smoothing ``v_eps``
        (rad/s).
    rolling_damping : float
        Rolling resistance ``b_psi`` (N m s/rad).
    actuator_time_constant, torque_limit : float
        Drive lag ``T_m`` (s) and torque limit (N m).
    fs : float
        Controller and sensor rate (Hz), the paper's 10 ms CAN cycle.
    angle_noise, rate_noise : float
        Sensor noise (rad, rad/s RMS).
    disturbance : float
        RMS of the random floor torque on the ball (N m, held per sample).

    Examples
    --------
    >>> rig = BallbotRig()
    >>> round(rig.unstable_pole(), 3)  # rad/s, frictionless closed form
    8.12
    """

    body_mass: float = 80.0
    com_height: float = 0.45
    body_inertia: float = 20.31
    ball_mass: float = 4.0
    ball_radius: float = 0.15
    ball_inertia: float = 0.06
    drive_damping: float = 0.5
    drive_coulomb: float = 1.5
    coulomb_velocity: float = 0.02
    rolling_damping: float = 0.2
    actuator_time_constant: float = 0.02
    torque_limit: float = 60.0
    gravity: float = 9.81
    fs: float = 100.0
    angle_noise: float = math.radians(0.02)
    rate_noise: float = math.radians(0.2)
    disturbance: float = 0.5

    def __post_init__(self):
        for k, v in asdict(self).items():
            if not (math.isfinite(v) and v >= 0):
                raise ModelError(f"BallbotRig parameter {k} must be >= 0; got {v!r}.")
        if self.body_inertia <= self.body_mass * self.com_height**2:
            raise ModelError(
                "body_inertia is about the ball centre and must exceed body_mass * "
                f"com_height^2 = {self.body_mass * self.com_height**2:.3g}; got "
                f"{self.body_inertia!r}."
            )

    def with_params(self, **values) -> BallbotRig:
        """A copy with some parameters changed."""
        return replace(self, **values)

    # ------------------------------------------------------------------ physics
    @property
    def _m11(self) -> float:
        return (self.ball_mass + self.body_mass) * self.ball_radius**2 + self.ball_inertia

    @property
    def _c(self) -> float:
        return self.body_mass * self.ball_radius * self.com_height

    def rhs(
        self,
        x: np.ndarray,
        u: np.ndarray | float,
        disturbance: np.ndarray | float = 0.0,
        *,
        coulomb: bool = True,
    ) -> np.ndarray:
        """``dx/dt`` for states ``(psi, theta, psi_rate, theta_rate, tau)`` (last axis).

        ``u`` is the torque command (saturated at ``torque_limit``); works on real and
        complex arrays (complex-step differentiation in :meth:`linearize`).
        """
        psi_d, th, psi_r, th_r, tau = (x[..., i] for i in range(5))
        del psi_d
        rel = psi_r - th_r
        fric = self.drive_damping * rel
        if coulomb and self.drive_coulomb:
            fric = fric + self.drive_coulomb * np.tanh(rel / self.coulomb_velocity)
        c, cos, sin = self._c, np.cos(th), np.sin(th)
        r_psi = tau - fric - self.rolling_damping * psi_r + c * sin * th_r**2 + disturbance
        r_th = -tau + fric + self.body_mass * self.gravity * self.com_height * sin
        det = self._m11 * self.body_inertia - (c * cos) ** 2
        acc_psi = (self.body_inertia * r_psi - c * cos * r_th) / det
        acc_th = (self._m11 * r_th - c * cos * r_psi) / det
        cmd = np.clip(u, -self.torque_limit, self.torque_limit) if np.isrealobj(u) else u
        dtau = (cmd - tau) / self.actuator_time_constant
        return np.stack([psi_r, th_r, acc_psi, acc_th, dtau], axis=-1)

    def unstable_pole(self) -> float:
        """The closed-form unstable pole (rad/s) of the upright plant."""
        det = self._m11 * self.body_inertia - self._c**2
        return math.sqrt(self.body_mass * self.gravity * self.com_height * self._m11 / det)

    def linearize(
        self, theta_rate: float = 0.0, *, actuator: bool = False, coulomb: bool = False
    ) -> LinearModel:
        """Exact linearisation at the upright tilt (complex-step Jacobians).

        Parameters
        ----------
        theta_rate : float, default 0.0
            Tilt rate (rad/s) at the operating point: the paper linearises at the
            angular velocity the body has when it swings through upright (its eq. 11),
            not at rest.
        actuator : bool, default False
            Include the drive lag: states gain ``tau``, the input is the command.
        coulomb : bool, default False
            Include the slope of the smoothed Coulomb friction (at rest it is a very
            stiff ``tau_c / v_eps``; at a tilt rate of several ``v_eps`` it vanishes).

        Returns
        -------
        LinearModel
            Outputs ``psi, theta, psi_rate, theta_rate``.

        Examples
        --------
        >>> lin = BallbotRig().linearize()
        >>> round(float(lin.poles.real.max()), 3)  # drive and rolling damping included
        7.387
        """
        x0 = np.array([0.0, 0.0, 0.0, float(theta_rate), 0.0])
        J = self.jacobians(np.array([float(theta_rate)]), coulomb=coulomb)[0]
        f0 = self.rhs(x0, 0.0, coulomb=coulomb)
        C = np.eye(4, 5)
        if actuator:
            A, B = J[:, :5], J[:, 5:]
            return LinearModel(
                A,
                B,
                C,
                np.zeros((4, 1)),
                x0,
                np.zeros(1),
                [*STATES, "tau"],
                ["u"],
                list(STATES),
                f0,
            )
        A, B = J[:4, :4], J[:4, 4:5]  # the torque itself is the input
        return LinearModel(
            A,
            B,
            C[:, :4],
            np.zeros((4, 1)),
            x0[:4],
            np.zeros(1),
            list(STATES),
            ["tau"],
            list(STATES),
            f0[:4],
        )

    def jacobians(self, theta_rates: ArrayLike, *, coulomb: bool = False) -> np.ndarray:
        """``[df/dx, df/du]`` (n, 5, 6) at upright tilt for each tilt rate (complex step).

        Complex-step differentiation (``f(x + i h e_j).imag / h`` with ``h = 1e-30``)
        is exact to rounding: no subtraction, no step-size trade-off.
        """
        rates = np.atleast_1d(np.asarray(theta_rates, dtype=float))
        x0 = np.zeros((rates.size, 5), dtype=complex)
        x0[:, 3] = rates
        h = 1e-30
        J = np.empty((rates.size, 5, 6))
        for j in range(6):
            xc = x0.copy()
            uc = np.zeros(rates.size, dtype=complex)
            if j < 5:
                xc[:, j] += 1j * h
            else:
                uc += 1j * h
            J[:, :, j] = self.rhs(xc, uc, coulomb=coulomb).imag / h
        return J

    def tilt_response(
        self,
        freq: ArrayLike,
        controller: BallbotController | None = None,
        theta_rate: ArrayLike = 0.0,
    ) -> np.ndarray:
        """The closed loop's ``theta / theta_set`` at ``freq`` (Hz), the linear model.

        The paper's reference transfer function ``G_w`` (sec. 5): plant, drive lag and
        the known controller, exactly sampled at ``fs`` (the controller's delay in place
        of the paper's dead time ``exp(-T_t s)``). ``theta_rate`` (rad/s, scalar or one
        per frequency) is the operating point of the linearisation (the paper's eq. 11).

        Examples
        --------
        >>> rig = BallbotRig()
        >>> round(float(abs(rig.tilt_response([0.5])[0])), 2)
        1.59
        """
        f = np.atleast_1d(np.asarray(freq, dtype=float))
        ctl = controller or self.controller()
        rates = np.broadcast_to(np.asarray(theta_rate, dtype=float), f.shape)
        uniq, inv = np.unique(rates, return_inverse=True)
        J = self.jacobians(uniq)
        n = 5
        M = np.zeros((uniq.size, n + 1, n + 1))
        M[:, :n, :] = J / self.fs
        E = linalg.expm(M)
        Ad, Bd = E[:, :n, :n], E[:, :n, n:]
        Cm = np.eye(4, 5)
        A = np.zeros((uniq.size, 9, 9))
        A[:, :5, :5] = Ad
        A[:, :5, 5:] = -Bd @ ctl.K[None, :]
        A[:, 5:, :5] = Cm
        B = np.zeros((uniq.size, 9, 1))
        B[:, :5] = Bd * ctl.N
        z = np.exp(2j * np.pi * f / self.fs)
        lhs = z[:, None, None] * np.eye(9) - A[inv]
        x = np.linalg.solve(lhs, B[inv].astype(complex))
        return x[:, 1, 0]

    # ------------------------------------------------------------------ control
    def controller(
        self, q: Sequence[float] = (1.0, 400.0, 1.0, 10.0), r: float = 0.02
    ) -> BallbotController:
        """LQR state feedback on the linearised plant (no actuator), ``N = K[1]``.

        The paper's controller "does not have to be optimally designed but must be
        known and constant" (sec. 3.3); LQR with weights ``q`` (states) and ``r``
        (torque) is one such design.
        """
        lin = self.linearize()
        P = linalg.solve_continuous_are(lin.A, lin.B, np.diag(q), np.array([[r]]))
        K = (lin.B.T @ P / r).ravel()
        return BallbotController(K, float(K[1]), self.fs, 1)

    def closed_loop(
        self, controller: BallbotController | None = None, theta_rate: float = 0.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Discrete closed loop ``w -> (x_meas, u)`` of the linear plant, exactly sampled.

        The plant with its drive lag, discretised with a zero-order hold at ``fs``, the
        controller ``u[k] = -K x[k - 1] + N w[k]``. Returns ``(A, B, C, D)``: states
        ``[plant (5), last measurement (4)]``, outputs the four measured states then
        ``u``.
        """
        ctl = controller or self.controller()
        Ad, Bd = self.discrete_plant(theta_rate)
        Cm = np.eye(4, 5)
        A = np.block([[Ad, -Bd @ ctl.K[None, :]], [Cm, np.zeros((4, 4))]])
        B = np.vstack([Bd * ctl.N, np.zeros((4, 1))])
        C = np.vstack([np.hstack([Cm, np.zeros((4, 4))]), np.r_[np.zeros(5), -ctl.K][None]])
        D = np.r_[np.zeros(4), ctl.N][:, None]
        return A, B, C, D

    def discrete_plant(self, theta_rate: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """``(Ad, Bd)``: plant and drive lag under a zero-order hold at ``fs``."""
        lin = self.linearize(theta_rate, actuator=True)
        n = lin.A.shape[0]
        E = linalg.expm(np.block([[lin.A, lin.B], [np.zeros((1, n + 1))]]) / self.fs)
        return E[:n, :n], E[:n, n:]

    # ------------------------------------------------------------------ simulation
    def simulate(
        self,
        reference: ArrayLike,
        *,
        controller: BallbotController | None = None,
        seed: int = 0,
        substeps: int = 4,
    ) -> BallbotRecord:
        """Closed-loop runs under the known controller, one per row of ``reference``.

        The nonlinear plant is integrated with RK4 (``substeps`` per controller
        period); the controller sees the noisy measurement of the previous period.

        Parameters
        ----------
        reference : array_like (n_runs, n) or (n,)
            Tilt set-point (rad) at ``fs`` (:func:`chirp_reference`).
        controller : BallbotController, optional
            Default :meth:`controller`.
        seed : int
            Seed of the sensor noise and the floor torque.
        substeps : int, default 4

        Returns
        -------
        BallbotRecord
        """
        w = np.atleast_2d(np.asarray(reference, dtype=float))
        if w.ndim != 2 or not np.all(np.isfinite(w)):
            raise DataError(f"reference must be finite, (n_runs, n); got shape {w.shape}.")
        ctl = controller or self.controller()
        runs, n = w.shape
        rng = np.random.default_rng(seed)
        noise_sd = np.r_[
            self.angle_noise, self.angle_noise, self.rate_noise, self.rate_noise
        ]
        meas_noise = rng.standard_normal((runs, n, 4)) * noise_sd
        dist = self.disturbance * rng.standard_normal((runs, n))
        x = np.zeros((runs, 5))
        prev = np.zeros((runs, 4))
        states = np.empty((runs, n, 4))
        cmd = np.empty((runs, n))
        dt = 1.0 / (self.fs * substeps)
        for k in range(n):
            meas = x[:, :4] + meas_noise[:, k]
            states[:, k] = meas
            u = np.clip(
                -prev @ ctl.K + ctl.N * w[:, k], -self.torque_limit, self.torque_limit
            )
            cmd[:, k] = u
            prev = meas
            d = dist[:, k]
            for _ in range(substeps):
                k1 = self.rhs(x, u, d)
                k2 = self.rhs(x + 0.5 * dt * k1, u, d)
                k3 = self.rhs(x + 0.5 * dt * k2, u, d)
                k4 = self.rhs(x + dt * k3, u, d)
                x = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            if not np.all(np.isfinite(x)) or np.abs(x[:, 1]).max() > 1.2:
                raise ModelError(
                    f"the ballbot fell over at t = {k / self.fs:.2f} s (tilt beyond 70 "
                    "degrees): the reference is too large for the torque limit."
                )
        amps = np.round(np.degrees(np.max(np.abs(w), axis=1)), 4)
        sat = np.mean(np.abs(cmd) >= self.torque_limit - 1e-9, axis=1)
        return BallbotRecord(
            np.arange(n) / self.fs,
            w,
            cmd,
            states,
            self.fs,
            amps,
            sat,
            {"rig": asdict(self), "K": ctl.K.tolist(), "N": ctl.N},
        )
