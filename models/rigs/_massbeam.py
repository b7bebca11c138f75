"""Physics model of the mass-beam fatigue rig of seed ``002`` (section 3).

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
from dataclasses import asdict, dataclass, replace

import numpy as np
import pandas as pd

from pdmkit.errors import ModelError

__all__ = ["MassBeamRig"]

_E_STEEL = 200e9  # Pa, mild steel
_E_AL = 68.9e9  # Pa, 6061-T6


def _rect_I(width: float, thickness: float) -> float:
    return width * thickness**3 / 12.0


@dataclass(frozen=True)
class MassBeamRig:
    """Parameters and linear models of the seed-002 mass-beam rig (SI units).

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
        """System-1 stiffness (N/m), seed 002 eq. (2)."""
        L4, L5 = self.L4, self.L5
        return 3 * self.E4I4 / (L4 * (3 * L5**2 - 3 * L5 * L4 + L4**2))

    def system1(self):
        """``(A, B, C, D)`` of system 1 (seed eqs. 4-5; ``B = 1/m3``, force input).

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
        forces at those points (seed 002, constants ``a1..a4``; ``a2 = a3`` by Maxwell's
        reciprocity).
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

    def system2(self):
        """``(A, B, C, D)`` of system 2, seed 002 eq. (8): states ``(y2, y2', y3, y3')``.

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

    def frequency_response(self, omega, *, damping: float = 0.0) -> np.ndarray:
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

    def to_pandas(self) -> pd.Series:
        """Parameters and resonances as a Series."""
        w = self.resonances()
        return pd.Series(
            {**asdict(self), "w_sys1": w[0], "w_sys2_low": w[1], "w_sys2_high": w[2]}
        )

    def plot(self, ax=None, *, damping: float = 0.01):
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
