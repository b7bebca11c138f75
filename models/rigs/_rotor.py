"""Simulated rotor rig of the rotor-diagnostics monograph (parametric rotor FDI).

The monograph's numerical model (section 4.1.1, Tables 11 and 12, model RM004K): a 10 mm
steel shaft of three sections (220, 50 and 220 mm) on four nodes; two disks of 0.9 kg
at nodes 2 and 3 (0.1 kg at nodes 1 and 4), each with an unbalance of 0.2 g at 35 mm
(phases 0 and 180 degrees); node 1 in a laterally rigid bearing, node 4 in a
hydrodynamic short bearing (clearance 150 um, viscosity 0.01 Pa s, length 55 mm,
diameter 40 mm). Four proximity probes measure the lateral vibration, ``ch1``/``ch2``
(x/y) on the motor side, ``ch3``/``ch4`` (x/y) at the hydrodynamic bearing.

What this module builds from it (the closest model to the monograph's RM Blockset one):

- the shaft: Euler-Bernoulli beam elements, the node rotations condensed out
  statically (Guyan), node masses lumped (the monograph's eq. 9: disk plus half of each
  adjacent section), stiffness-proportional structural damping; gyroscopic terms are
  left out (small disks at 30 Hz);
- the hydrodynamic bearing: the short-bearing (Ocvirk, pi-film) solution linearised at
  its static equilibrium under the rotor's weight, the eight stiffness and damping
  coefficients in closed form (Friswell et al., *Dynamics of Rotating Machines*, 2010,
  sec. 5.5); its cross-coupled stiffness gives the self-excited "0.5X" oil-whirl mode the
  monograph tracks (sec. 3.3). The journal sits in a housing of 0.5 kg on a flexible
  pedestal.
- probes: ``ch1, ch2`` the disk-1 displacement (the monograph's node 1 is a rigid
  bearing, so the motor-side probes look at the nearest moving node), ``ch3, ch4`` the
  journal relative to the housing ("relative shaft vibration inside bearing", sec. 1.1).

The four faults switch on during a run (:meth:`RotorRig.simulate`):

================  ==========================================================================
fault             physics (``severity = 1``)
================  ==========================================================================
``unbalance``     0.6 g more at 35 mm on disk 2, at 90 degrees
``misalignment``  coupling misalignment: the hydrodynamic bearing's static load doubles
                  (preload; the oil film stiffens) and a 2X force of 0.5 N acts on disk 1
``rub``           a seal above disk 2 closes to 4 um of the static position: partial
                  contact, contact stiffness 1e5 N/m, friction coefficient 0.2
``looseness``     a loose bolt under the hydrodynamic bearing: the pedestal's vertical
                  stiffness and damping drop to 35 %
================  ==========================================================================

Random forces on the disks (flow, foundation) excite the free vibration the monograph's
AR models identify; the record is simulated at ``oversample x fs`` (exact zero-order-hold
discretisation of the linear part, contact forces explicit) and decimated with an
anti-aliasing filter to the monograph's 256 Hz.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from scipy import linalg, optimize, signal

from pdmkit.errors import DataError, ModelError

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["ROTOR_FAULTS", "RotorRecord", "RotorRig", "short_bearing_coefficients"]

#: fault name -> what it is (the physics of each is in the module docstring)
ROTOR_FAULTS: dict[str, str] = {
    "unbalance": "added unbalance on disk 2",
    "misalignment": "coupling misalignment: bearing preload and a 2X force",
    "rub": "partial rub of disk 2 on a seal",
    "looseness": "loose pedestal bolt under the hydrodynamic bearing",
}

CHANNELS = ("ch1", "ch2", "ch3", "ch4")
RUB_GAP = 4e-6  # m, seal clearance above the static position (severity 1)
RUB_STIFFNESS = 1.0e5  # N/m
RUB_FRICTION = 0.2


def short_bearing_coefficients(
    load: float,
    speed: float,
    *,
    viscosity: float = 0.01,
    radius: float = 0.02,
    length: float = 0.055,
    clearance: float = 150e-6,
) -> tuple[float, np.ndarray, np.ndarray]:
    """Static eccentricity and linear coefficients of a short journal bearing.

    The short-bearing (Ocvirk) pi-film solution: the load ``W`` and the eccentricity
    ratio ``eps`` satisfy ``W = (mu Omega R L^3 / 4 c^2) eps sqrt(pi^2 (1 - eps^2) +
    16 eps^2) / (1 - eps^2)^2``; the stiffness ``K = (W / c) a`` and damping
    ``C = (W / (c Omega)) b`` coefficients are the closed forms of Friswell et al. (2010,
    eq. 5.72) in coordinates ``(x, y)`` with the load along ``-y`` (gravity): the bearing
    force on the journal is ``-K d - C v`` for a displacement ``d`` and velocity ``v``.

    Parameters
    ----------
    load : float
        Static load (N), > 0.
    speed : float
        Journal speed (rad/s), > 0.
    viscosity, radius, length, clearance : float
        Oil viscosity (Pa s), journal radius, bearing length and radial clearance (m).

    Returns
    -------
    eps : float
        Eccentricity ratio.
    K, C : ndarray (2, 2)
        Stiffness (N/m) and damping (N s/m), rows and columns ``(x, y)``.

    Examples
    --------
    >>> eps, K, C = short_bearing_coefficients(11.5, 2 * 3.141592653589793 * 30)
    >>> round(eps, 3), bool(K[0, 1] > 5 * K[0, 0])  # light load: cross-coupling rules
    (0.052, True)
    """
    for name, v in (("load", load), ("speed", speed), ("clearance", clearance)):
        if not (math.isfinite(v) and v > 0):
            raise ModelError(f"short bearing: {name} must be > 0; got {v!r}.")
    scale = viscosity * speed * radius * length**3 / (4 * clearance**2)

    def excess(e):
        return scale * e * math.sqrt(math.pi**2 * (1 - e**2) + 16 * e**2) / (1 - e**2) ** 2

    eps = optimize.brentq(lambda e: excess(e) - load, 1e-12, 1 - 1e-9, xtol=1e-14)
    e2, pi2 = eps**2, math.pi**2
    h0 = 1.0 / (pi2 * (1 - e2) + 16 * e2) ** 1.5
    root = math.sqrt(1 - e2)
    a = h0 * np.array(
        [
            [
                4 * (pi2 * (2 - e2) + 16 * e2),
                math.pi * (pi2 * (1 - e2) ** 2 - 16 * e2**2) / (eps * root),
            ],
            [
                -math.pi
                * (pi2 * (1 - e2) * (1 + 2 * e2) + 32 * e2 * (1 + e2))
                / (eps * root),
                4 * (pi2 * (1 + 2 * e2) + 32 * e2 * (1 + e2) / (1 - e2)),
            ],
        ]
    )
    bxy = -8 * (pi2 * (1 + 2 * e2) - 16 * e2)
    b = h0 * np.array(
        [
            [2 * math.pi * root * (pi2 * (1 + 2 * e2) - 16 * e2) / eps, bxy],
            [bxy, 2 * math.pi * (pi2 * (1 - e2) ** 2 + 48 * e2) / (eps * root)],
        ]
    )
    return eps, (load / clearance) * a, (load / (clearance * speed)) * b


@dataclass(eq=False)
class RotorRecord:
    """One simulated run of the rotor rig.

    Attributes
    ----------
    time : ndarray (n,)
        Seconds.
    channels : ndarray (n, 4)
        Probe signals ``ch1..ch4`` (m).
    fs : float
        Sampling rate (Hz).
    fault : str or None
        The fault that switches on (None: a healthy run).
    onset : float or None
        When it switches on (s).
    severity : float
    speed_hz : float
        Shaft speed (Hz): the 1X frequency.

    Examples
    --------
    >>> rec = RotorRig().simulate(2.0, seed=0)
    >>> rec.channels.shape, rec.to_pandas().columns.tolist()
    ((512, 4), ['time', 'ch1', 'ch2', 'ch3', 'ch4'])
    """

    time: np.ndarray
    channels: np.ndarray
    fs: float
    fault: str | None = None
    onset: float | None = None
    severity: float = 1.0
    speed_hz: float = 30.0
    info: dict = field(default_factory=dict, repr=False)

    def channel(self, name: str) -> np.ndarray:
        """One probe signal by name (``"ch1"`` .. ``"ch4"``)."""
        if name not in CHANNELS:
            raise DataError(f"channel must be one of {CHANNELS}; got {name!r}.")
        return self.channels[:, CHANNELS.index(name)]

    def to_pandas(self) -> pd.DataFrame:
        """Columns ``time, ch1..ch4`` (m)."""
        return pd.DataFrame(
            {"time": self.time, **dict(zip(CHANNELS, self.channels.T, strict=True))}
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """The four probe signals (um) against time, the fault onset marked; the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3))
        for k, name in enumerate(CHANNELS):
            ax.plot(self.time, 1e6 * self.channels[:, k], lw=0.5, label=name)
        if self.onset is not None:
            ax.axvline(self.onset, color="k", ls="--", lw=1, label=f"{self.fault} on")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("displacement [um]")
        ax.legend(loc="upper right", fontsize="small", ncol=5)
        return ax


@dataclass(frozen=True)
class RotorRig:
    """The monograph's rotor: two disks on a shaft, a rigid and a hydrodynamic bearing.

    Parameters
    ----------
    speed_hz : float, default 30.0
        Shaft speed (Hz); 1X, 2X and 3X stay below the 128 Hz Nyquist frequency.
    section_lengths : (float, float, float)
        Shaft sections between nodes 1-2, 2-3, 3-4 (m), Table 12.
    shaft_diameter, youngs_modulus, density : float
        Shaft (m, Pa, kg/m^3).
    node_masses : 4 floats
        Disk masses at nodes 1..4 (kg), Table 11 (node 1 sits in the rigid bearing).
    unbalance_masses, unbalance_phases_deg : 4 floats
        Unbalance (kg) at ``unbalance_radius`` (m) and its phase per node, Table 11.
    clearance, viscosity, bearing_length, bearing_diameter : float
        The hydrodynamic bearing at node 4, Table 11.
    outboard : {"hydrodynamic", "rigid"}
        ``"rigid"`` pins node 4 too (a simply supported shaft, for checks).
    housing_mass, pedestal_stiffness, pedestal_damping : float
        Bearing housing (kg) on its pedestal (N/m, damping ratio), x and y alike.
    shaft_damping : float
        Stiffness-proportional damping of the shaft (s).
    force_noise : float
        RMS random force on each disk and direction (N) over the simulated band.
    sensor_noise : float
        RMS probe noise (m).

    Examples
    --------
    >>> rig = RotorRig()
    >>> modes = rig.modes()
    >>> [round(f, 1) for f in modes["frequency_hz"][:3]]  # 0.5X whirl, bending x, y
    [15.1, 22.9, 23.0]
    """

    speed_hz: float = 30.0
    section_lengths: tuple = (0.220, 0.050, 0.220)
    shaft_diameter: float = 0.010
    youngs_modulus: float = 2.1e11
    density: float = 7850.0
    node_masses: tuple = (0.1, 0.9, 0.9, 0.1)
    unbalance_masses: tuple = (0.0, 0.2e-3, 0.2e-3, 0.0)
    unbalance_phases_deg: tuple = (0.0, 0.0, 180.0, 0.0)
    unbalance_radius: float = 0.035
    clearance: float = 150e-6
    viscosity: float = 0.01
    bearing_length: float = 0.055
    bearing_diameter: float = 0.040
    outboard: str = "hydrodynamic"
    housing_mass: float = 0.5
    pedestal_stiffness: float = 2.0e5
    pedestal_damping: float = 0.05
    shaft_damping: float = 2e-5
    force_noise: float = 0.5
    sensor_noise: float = 0.01e-6
    gravity: float = 9.81

    def __post_init__(self):
        if self.outboard not in ("hydrodynamic", "rigid"):
            raise ModelError(
                f"outboard must be 'hydrodynamic' or 'rigid'; got {self.outboard!r}."
            )
        if len(self.section_lengths) != 3 or min(self.section_lengths) <= 0:
            raise ModelError(
                "section_lengths must be three positive lengths (m); got "
                f"{self.section_lengths!r}."
            )
        if not self.speed_hz > 0:
            raise ModelError(f"speed_hz must be > 0; got {self.speed_hz!r}.")

    def with_params(self, **values) -> RotorRig:
        """A copy with some parameters changed."""
        return replace(self, **values)

    # ------------------------------------------------------------------ structure
    @property
    def omega(self) -> float:
        """Shaft speed (rad/s)."""
        return 2 * math.pi * self.speed_hz

    @property
    def node_positions(self) -> np.ndarray:
        """Axial positions of nodes 1..4 (m)."""
        return np.r_[0.0, np.cumsum(self.section_lengths)]

    def _beam(self) -> tuple[np.ndarray, np.ndarray]:
        """Full beam stiffness (w1, t1, ..., w4, t4) with EI of the shaft."""
        EI = self.youngs_modulus * math.pi * self.shaft_diameter**4 / 64
        K = np.zeros((8, 8))
        for e, L in enumerate(self.section_lengths):
            k = (EI / L**3) * np.array(
                [
                    [12, 6 * L, -12, 6 * L],
                    [6 * L, 4 * L * L, -6 * L, 2 * L * L],
                    [-12, -6 * L, 12, -6 * L],
                    [6 * L, 2 * L * L, -6 * L, 4 * L * L],
                ]
            )
            idx = np.arange(2 * e, 2 * e + 4)
            K[np.ix_(idx, idx)] += k
        return K, np.array([2, 4, 6])  # translations kept: w2, w3, w4 (w1 = 0)

    def shaft_stiffness(self) -> np.ndarray:
        """Lateral stiffness (N/m) of nodes 2, 3, 4 (node 1 pinned, rotations condensed).

        Static (Guyan) condensation of the beam's rotations: the stiffness the nodes
        show when only forces act on them.
        """
        K, t = self._beam()
        r = np.array([1, 3, 5, 7])
        return K[np.ix_(t, t)] - K[np.ix_(t, r)] @ np.linalg.solve(
            K[np.ix_(r, r)], K[np.ix_(r, t)]
        )

    def lumped_masses(self) -> np.ndarray:
        """Masses (kg) of nodes 2, 3, 4: disk plus half of each adjacent section."""
        area = math.pi * self.shaft_diameter**2 / 4
        sec = self.density * area * np.asarray(self.section_lengths, dtype=float)
        halves = np.r_[sec[0] + sec[1], sec[1] + sec[2], sec[2]] / 2
        return np.asarray(self.node_masses[1:], dtype=float) + halves

    def bearing_load(self, preload: float = 0.0) -> float:
        """Static load (N) on the hydrodynamic bearing: its weight share + ``preload``."""
        x = self.node_positions[1:]
        w = self.gravity * float(np.sum(self.lumped_masses() * x)) / x[-1]
        return w + preload

    def bearing_coefficients(
        self, preload: float = 0.0
    ) -> tuple[float, np.ndarray, np.ndarray]:
        """``(eps, K, C)`` of the hydrodynamic bearing (see short_bearing_coefficients)."""
        return short_bearing_coefficients(
            self.bearing_load(preload),
            self.omega,
            viscosity=self.viscosity,
            radius=self.bearing_diameter / 2,
            length=self.bearing_length,
            clearance=self.clearance,
        )

    # ------------------------------------------------------------------ linear model
    def matrices(
        self, fault: str | None = None, severity: float = 1.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mass, damping and stiffness matrices ``(M, C, K)`` of the lateral model.

        Degrees of freedom ``[x2, x3, x4, xh, y2, y3, y4, yh]`` (disks, journal,
        housing; ``[x2, x3, y2, y3]`` for a rigid outboard bearing). ``fault`` applies
        the linear faults (``"misalignment"``: bearing preload, ``"looseness"``: soft
        pedestal); the other faults act through forces in :meth:`simulate`.
        """
        _check_fault(fault)
        Ks = self.shaft_stiffness()
        m = self.lumped_masses()
        if self.outboard == "rigid":
            M = np.diag(np.r_[m[:2], m[:2]])
            K = linalg.block_diag(Ks[:2, :2], Ks[:2, :2])
            return M, self.shaft_damping * K, K
        pre = severity * self.bearing_load() if fault == "misalignment" else 0.0
        _, Kb, Cb = self.bearing_coefficients(pre)
        M = np.diag(np.r_[m, self.housing_mass, m, self.housing_mass])
        K = np.zeros((8, 8))
        for p in (0, 4):
            K[p : p + 3, p : p + 3] = Ks
        C = self.shaft_damping * K
        jour, hous = [2, 6], [3, 7]
        # film force on the journal -Kb (dj - dh), its reaction on the housing
        T = np.zeros((2, 8))
        T[[0, 1], jour], T[[0, 1], hous] = 1.0, -1.0
        K += T.T @ Kb @ T
        C += T.T @ Cb @ T
        kp = np.array([1.0, 1.0]) * self.pedestal_stiffness
        cp = 2 * self.pedestal_damping * np.sqrt(kp * self.housing_mass)
        if fault == "looseness":
            drop = 1.0 - 0.65 * min(max(severity, 0.0), 1.4)
            kp[1], cp[1] = kp[1] * drop, cp[1] * drop
        K[hous, hous] += kp
        C[hous, hous] += cp
        return M, C, K

    def state_space(
        self, fault: str | None = None, severity: float = 1.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C)``: states ``[q, dq]``, inputs the nodal forces, outputs ch1..ch4."""
        M, Cm, K = self.matrices(fault, severity)
        n = M.shape[0]
        A, B = _first_order(M, Cm, K)
        C = np.zeros((4, 2 * n))
        h = n // 2
        C[0, 0], C[1, h] = 1.0, 1.0
        if self.outboard == "hydrodynamic":
            C[2, 2], C[2, 3], C[3, 6], C[3, 7] = 1.0, -1.0, 1.0, -1.0
        return A, B, C

    def modes(self, fault: str | None = None, severity: float = 1.0) -> pd.DataFrame:
        """Natural frequencies (Hz) and damping ratios of the linear model, ascending.

        Examples
        --------
        >>> loose = RotorRig().modes("looseness")
        >>> healthy = RotorRig().modes()
        >>> bool(loose["frequency_hz"].iloc[-1] < healthy["frequency_hz"].iloc[-1])
        True
        """
        lam = np.linalg.eigvals(self.state_space(fault, severity)[0])
        lam = lam[lam.imag > 1e-9]
        wn = np.abs(lam)
        out = pd.DataFrame({"frequency_hz": wn / (2 * math.pi), "damping": -lam.real / wn})
        return out.sort_values("frequency_hz", ignore_index=True)

    # ------------------------------------------------------------------ simulation
    def simulate(
        self,
        duration: float,
        *,
        fs: float = 256.0,
        fault: str | None = None,
        onset: float | None = None,
        severity: float = 1.0,
        seed: int = 0,
        oversample: int = 8,
    ) -> RotorRecord:
        """Simulate a run; ``fault`` switches on at ``onset`` (default mid-run).

        Parameters
        ----------
        duration : float
            Seconds.
        fs : float, default 256.0
            Output sampling rate (Hz), the monograph's (sec. 4.2.1).
        fault : str, optional
            A key of :data:`ROTOR_FAULTS`; None: a healthy run.
        onset : float, optional
            When the fault switches on (s); default ``duration / 2``.
        severity : float, default 1.0
            Scales the fault (see the module docstring).
        seed : int
            Seed of the random forces and the probe noise.
        oversample : int, default 8
            Simulation steps per output sample.

        Returns
        -------
        RotorRecord
        """
        _check_fault(fault)
        if not duration > 0:
            raise DataError(f"duration must be > 0 s; got {duration!r}.")
        rate = float(fs) * int(oversample)
        n = round(duration * rate)
        onset = duration / 2 if (fault and onset is None) else onset
        k0 = n if not fault else round(float(np.clip(onset, 0, duration)) * rate)
        rng = np.random.default_rng(seed)
        t = np.arange(n) / rate
        forces = self._forces(t, rng, fault, severity, k0)
        healthy = _discretise(*self.state_space()[:2], 1.0 / rate)
        x = np.zeros(healthy[0].shape[0])
        states = np.empty((n, x.size))
        states[:k0], x = _propagate(healthy, forces[:k0], x)
        if k0 < n:
            if fault == "rub":
                states[k0:] = self._rub(forces[k0:], x, severity, 1.0 / rate)
            else:
                lin = fault if fault in ("misalignment", "looseness") else None
                system = _discretise(*self.state_space(lin, severity)[:2], 1.0 / rate)
                states[k0:], _ = _propagate(system, forces[k0:], x)
        out = states @ self.state_space()[2].T
        y = signal.decimate(out, int(oversample), ftype="fir", axis=0, zero_phase=True)
        y = y + self.sensor_noise * rng.standard_normal(y.shape)
        return RotorRecord(
            np.arange(y.shape[0]) / float(fs),
            y,
            float(fs),
            fault,
            None if not fault else float(k0 / rate),
            float(severity),
            self.speed_hz,
            {"rig": asdict(self)},
        )

    def _forces(self, t, rng, fault, severity, k0) -> np.ndarray:
        """Nodal forces (n, n_dof): random, unbalance, the fault's forcing from ``k0``."""
        ndof = 4 if self.outboard == "rigid" else 8
        h = ndof // 2
        f = np.zeros((t.size, ndof))
        # random forces on the disks (flow) and on the housing (foundation)
        nodes = [0, 1] if ndof == 4 else [0, 1, 3]
        cols = nodes + [h + d for d in nodes]
        f[:, cols] = self.force_noise * rng.standard_normal((t.size, len(cols)))
        w = self.omega
        for node in (1, 2):  # nodes 2 and 3 (disks)
            mu = self.unbalance_masses[node] * self.unbalance_radius * w**2
            ph = w * t + math.radians(self.unbalance_phases_deg[node])
            f[:, node - 1] += mu * np.cos(ph)
            f[:, h + node - 1] += mu * np.sin(ph)
        if fault == "unbalance":
            mu = severity * 0.6e-3 * self.unbalance_radius * w**2
            ph = w * t[k0:] + math.pi / 2
            f[k0:, 1] += mu * np.cos(ph)
            f[k0:, h + 1] += mu * np.sin(ph)
        elif fault == "misalignment":
            ph = 2 * w * t[k0:]
            f[k0:, 0] += severity * 0.5 * np.cos(ph)
            f[k0:, h] += severity * 0.5 * np.sin(ph)
        return f

    def _rub(self, forces, x, severity, dt) -> np.ndarray:
        """Step with the seal contact, exact in and out of contact.

        The seal sits half-way between disk 2 and the hydrodynamic bearing (the
        monograph's Table 9, C001/C002); its point moves as the mean of nodes 3 and 4 and
        its force is shared by them. Contact (the point above ``gap``) adds the contact
        stiffness to the linear model (normal force ``-k_c (y - gap)``, friction
        ``mu k_c (y - gap)`` along x against the surface speed), so each step is the exact
        zero-order-hold step of the piecewise-linear system it starts in.
        """
        M, C, K = self.matrices()
        ndof = M.shape[0]
        h = ndof // 2
        wx, wy = np.zeros(ndof), np.zeros(ndof)
        wx[[1, 2]], wy[[h + 1, h + 2]] = 0.5, 0.5
        gap = RUB_GAP / max(severity, 1e-6)
        Kc = K + RUB_STIFFNESS * (np.outer(wy, wy) - RUB_FRICTION * np.outer(wx, wy))
        const = RUB_STIFFNESS * gap * (wy - RUB_FRICTION * wx)
        free = _discretise(*_first_order(M, C, K), dt)
        touch = _discretise(*_first_order(M, C, Kc), dt)
        offset = touch[1] @ const
        out = np.empty((forces.shape[0], x.size))
        drive = [forces @ free[1].T, forces @ touch[1].T]
        wy_s = np.r_[wy, np.zeros(ndof)]
        for k in range(forces.shape[0]):
            out[k] = x
            if wy_s @ x > gap:
                x = touch[0] @ x + drive[1][k] + offset
            else:
                x = free[0] @ x + drive[0][k]
        return out


def _first_order(M, C, K):
    """``(A, B)`` of ``M q'' + C q' + K q = f`` with states ``[q, q']``."""
    n = M.shape[0]
    Minv = np.diag(1.0 / np.diag(M))
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    return A, np.vstack([np.zeros((n, n)), Minv])


def _check_fault(fault) -> None:
    if fault is not None and fault not in ROTOR_FAULTS:
        raise ModelError(
            f"fault must be one of {sorted(ROTOR_FAULTS)} or None; got {fault!r}."
        )


def _discretise(A: np.ndarray, B: np.ndarray, dt: float):
    """Exact zero-order-hold discretisation ``(Phi, Gamma)``."""
    n, m = B.shape
    E = linalg.expm(np.block([[A, B], [np.zeros((m, n + m))]]) * dt)
    return E[:n, :n], E[:n, n:]


def _propagate(system, forces: np.ndarray, x0: np.ndarray):
    """States ``x_k`` (before each step) of ``x_{k+1} = Phi x_k + Gamma f_k``, and the last.

    Diagonalised: each mode is a first-order recursion run by :func:`scipy.signal.lfilter`.
    """
    Phi, Gam = system
    if forces.shape[0] == 0:
        return np.zeros((0, x0.size)), x0
    lam, V = np.linalg.eig(Phi)
    g = np.linalg.solve(V, Gam @ forces.T)  # (n_states, n_steps)
    z0 = np.linalg.solve(V, x0.astype(complex))
    z = np.empty(g.shape, dtype=complex)
    last = np.empty(lam.size, dtype=complex)
    for i, li in enumerate(lam):
        z[i], zf = signal.lfilter([0.0, 1.0], [1.0, -li], g[i], zi=[z0[i]])
        last[i] = zf[0]
    return np.real(V @ z).T, np.real(V @ last)
