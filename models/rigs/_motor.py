"""Motor + gearbox rig: a DC motor driving a chain of gears (fractional-calculus study).

*Condition-based diagnosis of mechatronic systems using a fractional calculus
approach* (section 3) drives a gearbox of four
rapid-prototyped gears with a DC motor, measures the motor current (a shunt resistor)
and the vibration of the output bearing (an accelerometer), and describes each of its
four conditions by where the vibration starts and which way it travels to the two
sensors (section 3, figure 2): case 1, normal; case 2, a broken tooth in gear 2 (the
vibration reaches the accelerometer through gears 2, 3 and 4, the motor current through
the motor circuit); case 3, gear 3 (accelerometer through gears 3 and 4, current through
gears 1, 2, 3 and the motor); case 4, gear 4 (accelerometer through gear 4, current
through gears 1, 2, 3 and the motor). Its empirical transfer function is
``G_EETF = F{I} / F{V}`` (eq. 7): current over accelerometer voltage, 100-1000 rad/s.

This model is that transmission-path picture as a cascade of linear elements
(frequency domain, exact for fractional orders):

- the **source** of the vibration sits at position ``p`` of the chain: the motor's
  commutation and brush noise (``p = 0``, normal running) or the impacts of the broken
  tooth of gear 2, 3 or 4 (``p = 1, 2, 3``), a train of short pulses once per
  revolution of that gear whose timing scatters (the gear rattles in the gap the
  missing tooth leaves), so its spectrum is broadband;
- between the positions, three **mesh stages** (gears 1-2, 2-3, 3-4), each the
  transmissibility of a compliant mesh into the next gear's inertia with fractional
  (Bagley-Torvik) damping, as polymer gears have:
  ``S_k(s) = (1 + c_k s^mu) / (1 + c_k s^mu + s^2 / w_k^2)``,
  ``c_k = 2 zeta w_k^-mu`` (``zeta`` the damping ratio at the resonance ``w_k``);
- towards the **accelerometer**, the output-bearing housing (a lightly damped mode
  above the band) and the accelerometer: ``B(s) = K_a s^2 / (1 + 2 zeta_h s / w_h +
  s^2 / w_h^2)``;
- towards the **current**, the motor: a torque fluctuation changes the rotor speed
  ``1 / (J s + b)`` and the back-emf drives a current through the winding, whose
  impedance ``R + L s^gamma`` has a fractional inductive term (eddy currents in the
  iron, Retière & Ivanès, IEEE Trans. Energy Conversion 14(4), 1999):
  ``Y(s) = -K_e / ((J s + b)(R + L s^gamma))``.

So ``C_p = Y prod_{k <= p} S_k`` (current per unit source torque) and
``A_p = B prod_{k > p} S_k`` (accelerometer voltage), and the electrical transfer
function each condition shows the paper's method is ``C_p / A_p``: the conditions
differ by the path, as the paper explains them. The parameters are those of a small
(about 20 W) DC motor and plastic gears; the paper gives none, so they are assumptions,
chosen with the stage resonances inside the paper's band of 100-1000 rad/s.

A record adds what a real test varies and what its sensors add: the speed (the paper
records "at different speeds"), the meshes' stiffness (polymer stiffness drifts with
temperature; ``stiffness_spread``), and sensor noise (``noise`` times the record's
in-band RMS level, white, on both channels).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from pdmkit.errors import DataError, ModelError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["MOTOR_CONDITIONS", "MotorGearboxRig", "MotorRecord"]

#: the paper's four cases: name -> (case number, source position, description)
MOTOR_CONDITIONS: dict[str, tuple[int, int, str]] = {
    "normal": (1, 0, "Case 1: normal operation"),
    "gear2": (2, 1, "Case 2: broken tooth in gear 2"),
    "gear3": (3, 2, "Case 3: broken tooth in gear 3"),
    "gear4": (4, 3, "Case 4: broken tooth in gear 4"),
}


def _condition(condition: str) -> tuple[int, int, str]:
    if condition not in MOTOR_CONDITIONS:
        raise DataError(
            f"condition must be one of {list(MOTOR_CONDITIONS)}; got {condition!r}."
        )
    return MOTOR_CONDITIONS[condition]


@dataclass(frozen=True)
class MotorGearboxRig:
    """DC motor and a four-gear chain, the fractional-calculus paper's paths (SI).

    Parameters
    ----------
    R : float
        Winding resistance (ohm).
    L : float
        Coefficient of the winding's fractional inductive term (H s^(gamma - 1)).
    gamma : float
        Its order (1: a plain inductance; below 1: eddy currents).
    Ke : float
        Back-emf constant (V s/rad, = torque constant in N m/A).
    J, b : float
        Rotor (with gear 1) inertia (kg m^2) and viscous friction (N m s/rad).
    stage_w : tuple of 3 float
        Resonances (rad/s) of the mesh stages 1-2, 2-3, 3-4.
    stage_zeta : float
        Their damping ratio at resonance.
    mesh_order : float
        Order ``mu`` of the meshes' fractional damping (0.5: Bagley-Torvik).
    housing_w, housing_zeta : float
        Output-bearing housing resonance (rad/s) and damping ratio.
    accel_gain : float
        Accelerometer path gain ``K_a`` (V per unit source torque per (rad/s)^2; it
        scales the EETF, here to values of order 1 as the paper's table 1 shows).
    teeth : tuple of 4 int
        Teeth of gears 1..4 (the paper's gear 2 has nine).
    speed_hz : float
        Nominal motor speed (rev/s).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.rigs import MotorGearboxRig
    >>> rig = MotorGearboxRig()
    >>> w = np.array([100.0, 1000.0])
    >>> G = {c: rig.eetf(w, c) for c in ("normal", "gear4")}
    >>> bool(np.all(np.abs(G["normal"] - G["gear4"]) > 0))   # the path changes G
    True
    """

    R: float = 2.0
    L: float = 1.5e-3
    gamma: float = 0.8
    Ke: float = 0.03
    J: float = 3e-5
    b: float = 1e-5
    stage_w: tuple = (800.0, 450.0, 250.0)
    stage_zeta: float = 0.2
    mesh_order: float = 0.5
    housing_w: float = 3000.0
    housing_zeta: float = 0.05
    accel_gain: float = 1e-5
    teeth: tuple = (18, 9, 27, 36)
    speed_hz: float = 25.0

    def __post_init__(self):
        for k, v in asdict(self).items():
            vals = v if isinstance(v, tuple) else (v,)
            if not all(
                isinstance(x, int | float) and math.isfinite(x) and x > 0 for x in vals
            ):
                raise ModelError(
                    f"MotorGearboxRig parameter {k} must be positive and finite; got {v!r}."
                )
        if len(self.stage_w) != 3 or len(self.teeth) != 4:
            raise ModelError(
                "MotorGearboxRig needs 3 stage resonances (stage_w) and 4 tooth counts "
                f"(teeth); got {len(self.stage_w)} and {len(self.teeth)}."
            )

    # ------------------------------------------------------------------ paths
    def stage(self, s: ArrayLike, k: int, stiffness_scale: float = 1.0) -> np.ndarray:
        """Transmissibility ``S_k(s)`` of mesh stage ``k`` (0, 1, 2)."""
        w0 = self.stage_w[k]
        w = w0 * math.sqrt(stiffness_scale)
        mu = self.mesh_order
        c = 2 * self.stage_zeta * w0**-mu
        num = 1 + c * s**mu
        return num / (num + s**2 / w**2)

    def motor_admittance(self, s: ArrayLike) -> np.ndarray:
        """Current per unit torque at the rotor, ``-Ke / ((J s + b)(R + L s^gamma))``."""
        return -self.Ke / ((self.J * s + self.b) * (self.R + self.L * s**self.gamma))

    def housing(self, s: ArrayLike) -> np.ndarray:
        """Accelerometer voltage per unit force on the output bearing."""
        w, z = self.housing_w, self.housing_zeta
        return self.accel_gain * s**2 / (1 + 2 * z * s / w + s**2 / w**2)

    def paths(
        self,
        omega: ArrayLike,
        position: int,
        stiffness_scale: Sequence[float] = (1.0, 1.0, 1.0),
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(C_p, A_p)``: current and accelerometer voltage per unit source at ``p``.

        Parameters
        ----------
        omega : array_like
            Angular frequencies (rad/s), > 0.
        position : int
            0 (motor), 1, 2, 3 (gear 2, 3, 4).
        stiffness_scale : sequence of 3 float
            Factors on the three meshes' stiffness.
        """
        s = 1j * np.asarray(omega, dtype=float)
        C = self.motor_admittance(s).astype(complex)
        A = self.housing(s).astype(complex)
        for k in range(3):
            Sk = self.stage(s, k, float(stiffness_scale[k]))
            if k < position:
                C = C * Sk
            else:
                A = A * Sk
        return C, A

    def eetf(
        self,
        omega: ArrayLike,
        condition: str,
        stiffness_scale: Sequence[float] = (1.0, 1.0, 1.0),
    ) -> np.ndarray:
        """The transfer function current / accelerometer voltage of ``condition``.

        What the paper's empirical estimate (eq. 7) estimates, without noise.
        """
        _, p, _ = _condition(condition)
        C, A = self.paths(omega, p, stiffness_scale)
        return C / A

    # ------------------------------------------------------------------ records
    def simulate(
        self,
        condition: str,
        *,
        duration: float = 4.0,
        fs: float = 5000.0,
        rng: np.random.Generator | int | None = None,
        speed_spread: float = 0.2,
        stiffness_spread: float = 0.03,
        noise: float = 0.01,
        jitter: float = 0.3,
    ) -> MotorRecord:
        """One record of current and accelerometer voltage in ``condition``.

        Parameters
        ----------
        condition : str
            A key of :data:`MOTOR_CONDITIONS`.
        duration, fs : float
            Record length (s) and sampling rate (Hz).
        rng : numpy Generator or int, optional
        speed_spread : float
            The speed is uniform in ``speed_hz * (1 +- speed_spread)``.
        stiffness_spread : float
            Relative standard deviation of each mesh's stiffness in this record.
        noise : float
            Sensor noise standard deviation as a fraction of each channel's RMS level
            in 100-1000 rad/s.
        jitter : float
            Relative scatter of the intervals between impacts.

        Returns
        -------
        MotorRecord
        """
        _, p, _ = _condition(condition)
        rng = np.random.default_rng(rng)
        n = round(duration * fs)
        if n < 64 or not fs > 0:
            raise DataError(f"duration * fs must give >= 64 samples; got {n}.")
        f = np.fft.rfftfreq(n, 1 / fs)
        omega = 2 * np.pi * np.maximum(f, f[1] * 1e-3)
        speed = self.speed_hz * (1 + speed_spread * rng.uniform(-1, 1))
        scale = np.clip(1 + stiffness_spread * rng.normal(size=3), 0.5, 1.5)
        if p == 0:  # commutation and brush noise of the motor: broadband torque
            E = np.fft.rfft(rng.normal(size=n))
        else:  # the broken tooth: one impact per revolution of its gear, scattered
            gear_rate = speed * self.teeth[0] / self.teeth[p]
            E = self._impacts(gear_rate, n, fs, rng, jitter)
        C, A = self.paths(omega, p, scale)
        Ci, Vv = C * E, A * E
        band = (omega >= 100) & (omega <= 1000)
        i = np.fft.irfft(Ci, n)
        v = np.fft.irfft(Vv, n)
        for x, X in ((i, Ci), (v, Vv)):
            level = math.sqrt(2 * np.mean(np.abs(X[band]) ** 2)) / n if band.any() else 0
            x += noise * level * rng.normal(size=n)
        return MotorRecord(np.arange(n) / fs, i, v, fs, condition, speed, tuple(scale))

    @staticmethod
    def _impacts(rate, n, fs, rng, jitter, width=0.3e-3) -> np.ndarray:
        """Spectrum of a train of Gaussian pulses (``width`` s) at scattered times."""
        m = int(n / fs * rate * 2) + 4
        steps = np.clip(1 + jitter * rng.normal(size=m), 0.05, None) / rate
        t = rng.uniform(0, 1 / rate) + np.cumsum(steps)
        t = t[t < n / fs]
        x = np.zeros(n)
        np.add.at(x, (t * fs).astype(int), 1 + 0.2 * rng.normal(size=t.size))
        f = np.fft.rfftfreq(n, 1 / fs)
        return np.fft.rfft(x) * np.exp(-0.5 * (2 * np.pi * f * width) ** 2)

    def to_pandas(self) -> pd.Series:
        """Parameters as a Series."""
        d = asdict(self)
        return pd.Series(
            {k: (list(v) if isinstance(v, tuple) else v) for k, v in d.items()}
        )

    def plot(self, ax: Axes | None = None, *, omega: ArrayLike | None = None) -> Axes:
        """``|C_p / A_p|`` of the four conditions over 100-1000 rad/s; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        w = np.linspace(100, 1000, 400) if omega is None else np.asarray(omega)
        for name, (_, _, label) in MOTOR_CONDITIONS.items():
            ax.loglog(w, np.abs(self.eetf(w, name)), label=label)
        ax.set_xlabel("omega (rad/s)")
        ax.set_ylabel("|I / V|")
        ax.legend(fontsize=8)
        return ax


@dataclass
class MotorRecord:
    """One simulated record of :class:`MotorGearboxRig`.

    Attributes
    ----------
    time, current, accel : ndarray
        Time (s), motor current fluctuation and accelerometer voltage (model units).
    fs : float
    condition : str
    speed_hz : float
    stiffness_scale : tuple of float

    Examples
    --------
    >>> from pdmkit.models.rigs import MotorGearboxRig
    >>> record = MotorGearboxRig().simulate("normal", duration=0.5, rng=0)
    >>> record.condition, record.current.shape, record.fs
    ('normal', (2500,), 5000.0)
    """

    time: np.ndarray
    current: np.ndarray
    accel: np.ndarray
    fs: float
    condition: str
    speed_hz: float
    stiffness_scale: tuple

    def etfe(
        self,
        band: tuple[float, float] = (100.0, 1000.0),
        *,
        segment: float = 1.0,
        method: str = "h1",
        moving_average: int = 3,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The paper's empirical transfer function ``F{I} / F{V}`` (eq. 7) in ``band``.

        The accelerometer voltage is smoothed by a moving average (the paper filters it
        "using a moving average (MA) to reduce the effect of noise"), then
        Fourier-transformed with a Hann window of ``segment`` seconds.
        ``method="ratio"``: one window from the middle of the record, the plain ratio
        of eq. 7; ``"h1"``: the record cut into such windows (half overlap) and
        averaged, ``sum conj(V) I / sum |V|^2`` (the windows "reduce noise").

        Parameters
        ----------
        band : (float, float)
            Angular frequencies (rad/s) kept.

        Returns
        -------
        (freq, H)
            Frequencies (Hz) and complex values.
        """
        import scipy.signal as ss

        if method not in ("h1", "ratio"):
            raise ModelError(f"method must be 'h1' or 'ratio'; got {method!r}.")
        nseg = round(segment * self.fs)
        if nseg > self.current.size:
            raise DataError(
                f"segment of {segment} s needs {nseg} samples; the record has "
                f"{self.current.size}."
            )
        m = max(1, int(moving_average))
        v = np.convolve(self.accel, np.ones(m) / m, mode="same")
        i = self.current
        if method == "h1":
            f, pvi = ss.csd(v, i, fs=self.fs, window="hann", nperseg=nseg)
            _, pvv = ss.welch(v, fs=self.fs, window="hann", nperseg=nseg)
            H = pvi / pvv
        else:
            start = (i.size - nseg) // 2
            win = np.hanning(nseg)
            f = np.fft.rfftfreq(nseg, 1 / self.fs)
            seg = slice(start, start + nseg)
            H = np.fft.rfft(i[seg] * win) / np.fft.rfft(v[seg] * win)
        w = 2 * np.pi * f
        keep = (w >= band[0]) & (w <= band[1])
        return f[keep], H[keep]

    def to_pandas(self) -> pd.DataFrame:
        """Time, current and accelerometer voltage."""
        return pd.DataFrame(
            {"time": self.time, "current": self.current, "accel": self.accel}
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """The two channels over the first 0.2 s; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        k = self.time <= 0.2
        ax.plot(self.time[k], self.current[k] / np.std(self.current), label="current")
        ax.plot(self.time[k], self.accel[k] / np.std(self.accel), label="accelerometer")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("normalised")
        ax.legend()
        return ax
