"""Physics model of the mass-beam fatigue rig of Khatkhate, Ray & Keller (2007, section 3).

Khatkhate, Ray & Keller (2007) model their three-mass rig as two subsystems:

- **System 1** (section 3.1.1): mass ``m3`` on a steel cantilever driven by shaker 1;
  Castigliano's theorem gives the stiffness (eq. 2)
  ``k = 3 E I / (L4 (3 L5^2 - 3 L5 L4 + L4^2))`` and ``wn = sqrt(k / m3)`` (eq. 3).
- **System 2** (section 3.1.2): cantilever beam 1 (``E1 I1``, length ``L1``), the rigid
  mass ``m1`` (length ``L2``, displacement taken at its centre) and beam 2 (``E3 I3``,
  ``L3``) carrying ``m2`` at its tip, driven by shaker 2 at the tip. The flexibility
  coefficients ``a1..a4`` and the stiffnesses ``P, Q, R, S`` of the paper give the
  state-space model of eq. (8).

The paper reports 73.3 rad/s for system 1 and 28.9 and 87.8 rad/s for system 2. Table 1
gives the masses and the beam and specimen sections; with beam 1 of steel (800 x 25.4 x
12.7 mm, E = 200 GPa) and the force applied at the specimen length ``L5 = 203.2 mm``,
eq. (3) gives 73.15 rad/s. For system 2 the paper gives neither ``L1..L3`` nor how the
beam masses are lumped ("lumped representation of the beam masses", section 3); with
table 1's beam 1 (steel, 0.8 m), beam 2 (aluminium 6061-T6, 711.2 x 22.2 x 11.1 mm,
E = 68.9 GPa), ``L2 = 0`` and the bare masses (1.0 and 0.615 kg) the equations give 28.0
and 114.4 rad/s. The defaults therefore use *effective* (lumped) masses
``m1 = 1.952 kg`` and ``m2 = 0.503 kg``, calibrated so that the model reproduces the
paper's 28.9 and 87.8 rad/s; the rest is table 1.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from pdmkit.errors import ModelError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["FatigueRun", "MassBeamRig", "beam_fe_modes"]

_E_STEEL = 200e9  # Pa, mild steel
_E_AL = 68.9e9  # Pa, 6061-T6


def _rect_I(width: float, thickness: float) -> float:
    return width * thickness**3 / 12.0


@dataclass(frozen=True)
class MassBeamRig:
    """Parameters and linear models of Khatkhate et al.'s mass-beam rig (SI units).

    Parameters
    ----------
    m1, m2, m3 : float
        Masses (kg): ``m1`` between the beams of system 2, ``m2`` at the tip of beam 2,
        ``m3`` of system 1. ``m1``, ``m2`` default to effective lumped masses (see the
        module docstring); table 1 lists 1.0, 0.615 and 2.2 kg.
    E1I1, E3I3, E4I4 : float
        Flexural rigidities (N m^2) of beam 1, beam 2 and the system-1 cantilever.
    L1, L2, L3 : float
        Lengths (m) of beam 1, of mass ``m1`` and of beam 2.
    L4, L5 : float
        System-1 beam length and the distance at which shaker 1 acts (m).

    Examples
    --------
    >>> from pdmkit.models.rigs._massbeam import MassBeamRig
    >>> rig = MassBeamRig()
    >>> [round(w, 1) for w in rig.resonances()]
    [73.2, 28.9, 87.8]
    """

    m1: float = 1.952
    m2: float = 0.503
    m3: float = 2.2
    E1I1: float = _E_STEEL * _rect_I(25.4e-3, 12.7e-3)
    E3I3: float = _E_AL * _rect_I(22.2e-3, 11.1e-3)
    E4I4: float = _E_STEEL * _rect_I(25.4e-3, 12.7e-3)
    L1: float = 0.8
    L2: float = 0.0
    L3: float = 0.7112
    L4: float = 0.8
    L5: float = 0.2032

    def __post_init__(self):
        for k, v in asdict(self).items():
            if not (math.isfinite(v) and (v > 0 or (k == "L2" and v == 0))):
                raise ModelError(
                    f"MassBeamRig parameter {k} must be a positive finite number (SI "
                    f"units); got {v!r}."
                )

    def with_params(self, **values) -> MassBeamRig:
        """A copy with some parameters changed (e.g. a cracked, softer beam).

        Examples
        --------
        >>> from pdmkit.models.rigs._massbeam import MassBeamRig
        >>> soft = MassBeamRig().with_params(E4I4=0.81 * MassBeamRig().E4I4)
        >>> round(soft.resonances()[0] / MassBeamRig().resonances()[0], 3)
        0.9
        """
        return replace(self, **values)

    # ------------------------------------------------------------------ system 1
    def stiffness1(self) -> float:
        """System-1 stiffness (N/m), Khatkhate et al. eq. (2)."""
        L4, L5 = self.L4, self.L5
        return 3 * self.E4I4 / (L4 * (3 * L5**2 - 3 * L5 * L4 + L4**2))

    def system1(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C, D)`` of system 1 (the paper's eqs. 4-5; ``B = 1/m3``, force input).

        The paper prints ``B = (0, 1)`` for the equation ``m x'' + k x = F1``; here the
        input is the force, so ``B = (0, 1/m3)``.
        """
        k = self.stiffness1()
        A = np.array([[0.0, 1.0], [-k / self.m3, 0.0]])
        B = np.array([[0.0], [1.0 / self.m3]])
        C = np.array([[1.0, 0.0]])
        return A, B, C, np.zeros((1, 1))

    # ------------------------------------------------------------------ system 2
    def flexibility2(self) -> np.ndarray:
        """Flexibility matrix ``[[a1, a2], [a3, a4]]`` (m/N) of system 2.

        Displacements of ``m1`` (at the centre of its length) and of ``m2`` under unit
        forces at those points (Khatkhate et al., constants ``a1..a4``; ``a2 = a3`` by
        Maxwell's reciprocity).
        """
        L1, L2, L3, EI1, EI3 = self.L1, self.L2, self.L3, self.E1I1, self.E3I3
        a1 = (4 * L1**3 + 6 * L1**2 * L2 + 3 * L1 * L2**2) / (12 * EI1)
        a2 = (
            4 * L1**3 + 9 * L1**2 * L2 + 6 * L1 * L2**2 + 6 * L1**2 * L3 + 6 * L1 * L2 * L3
        ) / (12 * EI1)
        a4 = (
            L1**3 / (3 * EI1)
            + L3**3 / (3 * EI3)
            + (L1**2 * L2 + L1 * L2**2 + L1**2 * L3 + L1 * L3**2 + 2 * L1 * L2 * L3) / EI1
        )
        return np.array([[a1, a2], [a2, a4]])

    def system2(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C, D)`` of system 2 (eq. 8): states ``(y2, y2', y3, y3')``.

        ``P, Q, R, S`` are the entries of the inverse flexibility matrix; the input is
        shaker 2's force on ``m2``, the outputs the displacements of ``m1`` and ``m2``.
        """
        (a1, a2), (a3, a4) = self.flexibility2()
        det = a1 * a4 - a2 * a3
        P, Q, R, S = a4 / det, -a2 / det, -a3 / det, a1 / det
        m1, m2 = self.m1, self.m2
        A = np.array(
            [
                [0.0, 1.0, 0.0, 0.0],
                [-P / m1, 0.0, -Q / m1, 0.0],
                [0.0, 0.0, 0.0, 1.0],
                [-R / m2, 0.0, -S / m2, 0.0],
            ]
        )
        B = np.array([[0.0], [0.0], [0.0], [1.0 / m2]])
        C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
        return A, B, C, np.zeros((2, 1))

    # ------------------------------------------------------------------ summary
    def resonances(self) -> list[float]:
        """Undamped natural frequencies (rad/s): system 1, then system 2 ascending."""
        w1 = math.sqrt(self.stiffness1() / self.m3)
        w2 = np.sort(np.abs(np.linalg.eigvals(self.system2()[0]).imag))[::2]
        return [w1, *map(float, w2)]

    def frequency_response(self, omega: ArrayLike, *, damping: float = 0.0) -> np.ndarray:
        """Receptances (m/N) at ``omega`` rad/s, rows: ``m3/F1``, ``m1/F2``, ``m2/F2``.

        ``damping`` adds a modal damping ratio (the paper's structure is lightly damped;
        undamped FRFs are infinite at resonance).

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models.rigs._massbeam import MassBeamRig
        >>> rig = MassBeamRig()
        >>> H = rig.frequency_response(np.array([0.0]))
        >>> bool(np.isclose(H[0, 0].real, 1 / rig.stiffness1()))
        True
        """
        w = np.asarray(omega, dtype=float)
        s = 1j * w
        out = []
        A1, B1, C1, _ = self.system1()
        A2, B2, C2, _ = self.system2()
        for A, B, C in ((A1, B1, C1), (A2, B2, C2)):
            if damping:
                # proportional damping: C/M = 2 zeta sqrt(M^-1 K)
                K = -A[1::2, 0::2]  # M^-1 K
                lam, V = np.linalg.eig(K)
                Cd = V @ np.diag(2 * damping * np.sqrt(lam.real)) @ np.linalg.inv(V)
                A = A.copy()
                A[1::2, 1::2] = -Cd.real
            for i in range(C.shape[0]):
                out.append(
                    np.array(
                        [
                            (C[i] @ np.linalg.solve(si * np.eye(A.shape[0]) - A, B)).item()
                            for si in s
                        ]
                    )
                )
        return np.array(out)

    # ------------------------------------------------------------------ fatigue
    def vibration_record(
        self,
        stiffness: float | ArrayLike | None = None,
        *,
        breathing: bool = True,
        duration: float = 120.0,
        fs: float = 500.0,
        force_amplitude: float = 8.5,
        frequency_hz: float = 11.39,
        damping: float = 0.01,
        force_noise: float = 0.03,
        force_drift: float = 0.005,
        sensor_noise: float = 5e-5,
        warmup: float = 10.0,
        rng: np.random.Generator | int | None = None,
    ) -> np.ndarray:
        """Displacement of ``m3`` (m) under shaker 1's sine, as in the paper's section 6.

        ``m3 x'' + c x' + k(x) x = F0 sin(2 pi f t) + w(t)``: the shaker's sine (0.85 V
        at 11.39 Hz in the paper; ``force_amplitude`` = 8.5 N assumes 10 N/V; from record
        to record its gain drifts, a relative standard deviation ``force_drift``, as an
        amplifier and a shaker warming up do) plus white force noise of
        ``force_noise * F0`` standard deviation, ``c = 2 zeta sqrt(k0 m3)`` fixed by the
        uncracked stiffness ``k0``, sampled at ``fs`` (the paper's 2 ms) after
        ``warmup`` seconds (the paper records "after the dynamic response attained the
        stationary behavior"), plus LVDT noise of ``sensor_noise`` m.

        ``stiffness`` is the stiffness with the crack open. A fatigue crack *breathes*
        (Gudmundson, J. Sound Vib. 1983; Chati, Rand & Mukherjee, J. Sound Vib. 1997):
        it opens on one side of the motion and closes on the other, so with
        ``breathing`` (default) ``k(x) = stiffness`` for ``x > 0`` and ``k0`` for
        ``x <= 0`` (a bilinear oscillator, integrated by RK4 at twice ``fs``);
        without, ``k = stiffness`` throughout (exact ZOH discretisation).

        Parameters
        ----------
        stiffness : float or array_like, optional
            Open-crack stiffness (N/m), default ``k0``; an array gives one record per
            value (a batch).

        Returns
        -------
        ndarray, shape (n,) or (len(stiffness), n)

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models.rigs import MassBeamRig
        >>> x = MassBeamRig().vibration_record(duration=10.0, rng=0)
        >>> x.shape, bool(0.005 < np.std(x) < 0.02)
        ((5000,), True)
        """
        k0 = self.stiffness1()
        scalar = stiffness is None or np.ndim(stiffness) == 0
        k = np.atleast_1d(np.asarray(k0 if stiffness is None else stiffness, dtype=float))
        if not (np.all(k > 0) and fs > 0 and duration > 0):
            raise ModelError(
                f"stiffness, fs and duration must be positive; got {k}, {fs}, {duration}."
            )
        rng = np.random.default_rng(rng)
        m = self.m3
        c = 2 * damping * math.sqrt(k0 * m)
        n_warm = round(warmup * fs)
        n = round(duration * fs)
        t = np.arange(n_warm + n) / fs
        B = k.size
        phase = rng.uniform(0, 2 * np.pi, size=(B, 1))
        gain = 1 + force_drift * rng.normal(size=(B, 1))
        force = gain * force_amplitude * np.sin(2 * np.pi * frequency_hz * t + phase)
        force += force_noise * force_amplitude * rng.normal(size=force.shape)
        if breathing:
            x = _bilinear_rk4(force, k, np.full(B, k0), m, c, fs)[:, n_warm:]
        else:
            import scipy.signal as ss

            x = np.empty((B, n))
            for i, ki in enumerate(k):
                sysd = ss.cont2discrete(([1.0], [m, c, ki]), 1 / fs, method="zoh")
                x[i] = ss.lfilter(np.ravel(sysd[0]), sysd[1], force[i])[n_warm:]
        x = x + sensor_noise * rng.normal(size=x.shape)
        return x[0] if scalar else x

    def _crack_model(self, force_amplitude, frequency_hz, damping, geometry):
        """Functions of the crack length ``a`` (m): stiffness and Paris growth rate."""
        hole, width, share, m_paris = geometry
        k0, m = self.stiffness1(), self.m3
        w_e = 2 * np.pi * frequency_hz
        c = 2 * damping * math.sqrt(k0 * m)
        ligament = (width - hole) / 2

        def stiffness(a):
            w = 1 - np.asarray(a) / ligament
            return k0 / ((1 - share) + share / w)

        def effective(k_open):  # bilinear: w_eff = 2 w1 w2 / (w1 + w2)
            return 4 * k_open * k0 / (np.sqrt(k_open) + np.sqrt(k0)) ** 2

        def rate(a):  # da/dt up to Paris' constant: (net-section stress range)^m (pi a)^m/2
            k = effective(stiffness(a))
            amp = force_amplitude / np.sqrt((k - m * w_e**2) ** 2 + (c * w_e) ** 2)
            w = 1 - np.asarray(a) / ligament
            return (amp / w) ** m_paris * (np.pi * np.asarray(a)) ** (m_paris / 2)

        return stiffness, rate, ligament, k0, effective

    def fatigue_run(
        self,
        *,
        n_files: int = 18,
        file_minutes: float = 2.0,
        record_seconds: float | None = None,
        fs: float = 500.0,
        life_minutes: float = 40.0,
        crack0_mm: float = 1.0,
        paris_exponent: float = 3.7,
        compliance_share: float = 0.05,
        hole_mm: float = 8.43,
        width_mm: float = 22.2,
        fail_ligament: float = 0.05,
        force_amplitude: float = 8.5,
        frequency_hz: float = 11.39,
        damping: float = 0.01,
        rng: np.random.Generator | int | None = None,
        **record_options: Any,
    ) -> FatigueRun:
        """A fatigue run of system 1 to failure, recorded in files (section 6).

        The specimen (aluminium, ``width_mm`` x 11.1 mm, a hole of ``hole_mm``, table 1
        and section 2) cracks from both edges of its hole. The crack length ``a``
        grows by Paris' law ``da/dN = C (Delta K)^m`` with ``Delta K`` from the
        net-section stress range, which is proportional to the displacement amplitude
        over the remaining ligament share ``w = 1 - a / a_max``; the cracked specimen,
        which holds ``compliance_share`` of system 1's compliance when whole, softens
        the system when the crack is open, ``k = k0 / ((1 - s) + s / w)`` (it breathes:
        :meth:`vibration_record`), and the amplitude at the fixed excitation (11.39 Hz,
        just below the resonance of 11.64 Hz) rises as the effective stiffness of the
        bilinear system (``w_eff = 2 w_open w0 / (w_open + w0)``) falls: the crack
        speeds itself up. ``C`` is set so that the specimen breaks
        (``w = fail_ligament``) at ``life_minutes`` (the paper: about 40 min, section 6).
        Files of ``file_minutes`` are recorded one after another from the start; each
        holds ``record_seconds`` (default the whole file) of :meth:`vibration_record`
        at the stiffness of the file's middle. ``record_options`` go to
        :meth:`vibration_record`.

        Returns
        -------
        FatigueRun

        Examples
        --------
        >>> from pdmkit.models.rigs import MassBeamRig
        >>> run = MassBeamRig().fatigue_run(n_files=4, record_seconds=5.0, rng=0)
        >>> run.records.shape
        (4, 2500)
        >>> bool(run.stiffness_loss[-1] > run.stiffness_loss[0] > 0)
        True
        """
        from scipy.integrate import cumulative_trapezoid

        if n_files * file_minutes >= life_minutes:
            raise ModelError(
                f"n_files * file_minutes ({n_files * file_minutes} min) must end before "
                f"the specimen breaks at life_minutes={life_minutes}."
            )
        geometry = (hole_mm * 1e-3, width_mm * 1e-3, compliance_share, paris_exponent)
        stiffness, rate, ligament, k0, effective = self._crack_model(
            force_amplitude, frequency_hz, damping, geometry
        )
        a = np.geomspace(crack0_mm * 1e-3, (1 - fail_ligament) * ligament, 4000)
        t_rel = cumulative_trapezoid(1 / rate(a), a, initial=0.0)
        t_min = life_minutes * t_rel / t_rel[-1]
        ends = file_minutes * np.arange(1, n_files + 1)
        a_files = np.interp(ends - file_minutes / 2, t_min, a)
        k_files = stiffness(a_files)
        m, w_e = self.m3, 2 * np.pi * frequency_hz
        c = 2 * damping * math.sqrt(k0 * m)
        k_eff = effective(k_files) if record_options.get("breathing", True) else k_files
        amp = force_amplitude / np.sqrt((k_eff - m * w_e**2) ** 2 + (c * w_e) ** 2)
        secs = file_minutes * 60 if record_seconds is None else float(record_seconds)
        records = self.vibration_record(
            k_files,
            duration=secs,
            fs=fs,
            force_amplitude=force_amplitude,
            frequency_hz=frequency_hz,
            damping=damping,
            rng=rng,
            **record_options,
        )
        sel = np.unique(np.r_[np.linspace(0, a.size - 1, 400).astype(int), a.size - 1])
        curve = pd.DataFrame(
            {
                "time_min": t_min[sel],
                "crack_mm": 1e3 * a[sel],
                "stiffness_loss": 1 - stiffness(a[sel]) / k0,
            }
        )
        curve.attrs["k0"] = k0
        return FatigueRun(
            ends, records, fs, k_files, 1e3 * a_files, amp, float(life_minutes), curve
        )

    def distributed_resonances(
        self,
        *,
        rho1: float = 7850.0,
        rho3: float = 2700.0,
        area1: float = 25.4e-3 * 12.7e-3,
        area3: float = 22.2e-3 * 11.1e-3,
        m1: float = 1.0,
        m2: float = 0.615,
        n_elements: int = 24,
    ) -> list[float]:
        """System 2's two lowest resonances (rad/s) with the beams' own mass distributed.

        :func:`beam_fe_modes` of beam 1 (steel, ``E1I1``, ``L1``) and beam 2 (aluminium,
        ``E3I3``, ``L3``) with table 1's bare masses ``m1`` at their joint and ``m2`` at
        the tip (``L2 = 0``): the physics that the lumped model of eq. (8) leaves out
        (Khatkhate et al.'s section 3 lumps the beam masses; it gives 28.9 and 87.8
        rad/s).

        Examples
        --------
        >>> from pdmkit.models.rigs import MassBeamRig
        >>> [round(w, 1) for w in MassBeamRig().distributed_resonances()]
        [24.4, 88.4]
        """
        w = beam_fe_modes(
            [(self.E1I1, rho1 * area1, self.L1), (self.E3I3, rho3 * area3, self.L3)],
            {0: m1, 1: m2},
            n_elements=n_elements,
            n_modes=2,
        )
        return [float(v) for v in w]

    def to_pandas(self) -> pd.Series:
        """Parameters and resonances as a Series."""
        w = self.resonances()
        return pd.Series(
            {**asdict(self), "w_sys1": w[0], "w_sys2_low": w[1], "w_sys2_high": w[2]}
        )

    def plot(self, ax: Axes | None = None, *, damping: float = 0.01) -> Axes:
        """Receptance magnitudes from 1 to 150 rad/s; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        w = np.linspace(1, 150, 1500)
        H = self.frequency_response(w, damping=damping)
        for row, lab in zip(H, ["m3/F1", "m1/F2", "m2/F2"], strict=True):
            ax.semilogy(w, np.abs(row), label=lab)
        ax.set_xlabel("omega (rad/s)")
        ax.set_ylabel("|receptance| (m/N)")
        ax.legend()
        return ax


def _bilinear_rk4(force, k_open, k_closed, m, c, fs, substeps: int = 2) -> np.ndarray:
    """Batched RK4 of ``m x'' + c x' + k(x) x = F`` with ``k = k_open`` for ``x > 0``.

    ``force`` is ``(batch, n)``, held over each sample; returns ``x`` at the samples.
    """
    B, n = force.shape
    h = 1.0 / (fs * substeps)
    x = np.zeros(B)
    v = np.zeros(B)
    out = np.empty((B, n))
    inv_m = 1.0 / m

    def acc(xx, vv, f):
        return (f - c * vv - np.where(xx > 0, k_open, k_closed) * xx) * inv_m

    for i in range(n):
        f = force[:, i]
        for _ in range(substeps):
            a1 = acc(x, v, f)
            x2, v2 = x + 0.5 * h * v, v + 0.5 * h * a1
            a2 = acc(x2, v2, f)
            x3, v3 = x + 0.5 * h * v2, v + 0.5 * h * a2
            a3 = acc(x3, v3, f)
            x4, v4 = x + h * v3, v + h * a3
            a4 = acc(x4, v4, f)
            x = x + h / 6 * (v + 2 * v2 + 2 * v3 + v4)
            v = v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        out[:, i] = x
    return out


# ---------------------------------------------------------------------- beam FE
def beam_fe_modes(
    segments: Sequence[tuple[float, float, float]],
    point_masses: Mapping[int, float] | None = None,
    *,
    n_elements: int = 24,
    n_modes: int = 4,
) -> np.ndarray:
    """Natural frequencies (rad/s) of a clamped-free Euler-Bernoulli beam (finite elements).

    Cubic Hermite elements with consistent mass matrices (Przemieniecki 1968); the beam
    is clamped at ``x = 0`` and made of ``segments`` one after another, each
    ``(EI, rho_A, length)`` (N m^2, kg/m, m); ``point_masses`` maps a segment index to
    a mass (kg) at that segment's far end. It converges to the exact continuous beam
    as ``n_elements`` (per segment) grows; with no point mass the first two
    frequencies of a uniform cantilever are ``(1.8751, 4.6941)^2 sqrt(EI / (rho_A
    L^4))``.

    Parameters
    ----------
    segments : sequence of (float, float, float)
    point_masses : dict of int -> float, optional
    n_elements : int, default 24
    n_modes : int, default 4

    Returns
    -------
    ndarray, shape (n_modes,)

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.rigs import beam_fe_modes
    >>> w = beam_fe_modes([(1.0, 1.0, 1.0)], n_modes=2)
    >>> np.round(w / np.array([1.8751, 4.6941]) ** 2, 4)
    array([1., 1.])
    """
    import scipy.linalg as sl

    segs = [tuple(float(v) for v in seg) for seg in segments]
    if not segs or any(len(s) != 3 or min(s) <= 0 for s in segs):
        raise ModelError(
            "segments must be a non-empty sequence of positive (EI, rho_A, length); "
            f"got {segments!r}."
        )
    ne = int(n_elements)
    n_nodes = len(segs) * ne + 1
    K = np.zeros((2 * n_nodes, 2 * n_nodes))
    M = np.zeros_like(K)
    for i, (EI, rA, length) in enumerate(segs):
        h = length / ne
        k = (EI / h**3) * np.array(
            [
                [12, 6 * h, -12, 6 * h],
                [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                [-12, -6 * h, 12, -6 * h],
                [6 * h, 2 * h * h, -6 * h, 4 * h * h],
            ]
        )
        m = (rA * h / 420) * np.array(
            [
                [156, 22 * h, 54, -13 * h],
                [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                [54, 13 * h, 156, -22 * h],
                [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
            ]
        )
        for e in range(ne):
            sl_ = slice(2 * (i * ne + e), 2 * (i * ne + e) + 4)
            K[sl_, sl_] += k
            M[sl_, sl_] += m
    for seg, mass in (point_masses or {}).items():
        node = (int(seg) + 1) * ne
        M[2 * node, 2 * node] += float(mass)
    w2 = sl.eigh(K[2:, 2:], M[2:, 2:], eigvals_only=True)
    return np.sqrt(np.abs(w2[: int(n_modes)]))


# ---------------------------------------------------------------------- fatigue
@dataclass
class FatigueRun:
    """A simulated fatigue run of system 1 (:meth:`MassBeamRig.fatigue_run`).

    Attributes
    ----------
    time_min : ndarray, shape (n_files,)
        End of each file (min); file ``i`` covers the two minutes before it.
    records : ndarray, shape (n_files, n_samples)
        Displacement of mass ``m3`` (m), the LVDT signal of each file.
    fs : float
        Sampling rate (Hz).
    stiffness : ndarray
        System-1 stiffness in each file (N/m).
    crack_mm : ndarray
        Crack length from the edge of the hole in each file (mm).
    amplitude : ndarray
        Steady-state displacement amplitude at the excitation (m).
    life_min : float
        When the specimen breaks (min).
    curve : pandas.DataFrame
        The slow-time history (``time_min``, ``crack_mm``, ``stiffness_loss``).

    Examples
    --------
    >>> from pdmkit.models.rigs import MassBeamRig
    >>> run = MassBeamRig().fatigue_run(n_files=3, record_seconds=4.0)
    >>> run.records.shape, run.life_min
    ((3, 2000), 40.0)
    >>> bool(run.stiffness[-1] < run.stiffness[0])  # the crack softens the beam
    True
    """

    time_min: np.ndarray
    records: np.ndarray
    fs: float
    stiffness: np.ndarray
    crack_mm: np.ndarray
    amplitude: np.ndarray
    life_min: float
    curve: pd.DataFrame

    @property
    def stiffness_loss(self) -> np.ndarray:
        """``1 - k / k0`` of each file (k0: the uncracked stiffness)."""
        return 1 - self.stiffness / self.curve.attrs["k0"]

    def to_pandas(self) -> pd.DataFrame:
        """One row per file: time, crack, stiffness, stiffness loss, amplitude, RMS."""
        return pd.DataFrame(
            {
                "time_min": self.time_min,
                "crack_mm": self.crack_mm,
                "stiffness": self.stiffness,
                "stiffness_loss": self.stiffness_loss,
                "amplitude_mm": 1e3 * self.amplitude,
                "rms_mm": 1e3 * np.sqrt(np.mean(self.records**2, axis=1)),
            }
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """Stiffness loss (%) and crack length over the run; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        c = self.curve
        ax.plot(c["time_min"], 100 * c["stiffness_loss"], label="stiffness loss (%)")
        ax.plot(c["time_min"], c["crack_mm"], "--", label="crack (mm)")
        ax.plot(self.time_min, 100 * self.stiffness_loss, "o", label="files")
        ax.axvline(self.life_min, color="k", lw=0.8)
        ax.set_xlabel("time (min)")
        ax.legend()
        return ax
