"""Which of the file's fixed constants deserve a fit: a first-order score test.

A model file fixes many constants (the rig's holds 23: gas constants, areas, dead
volumes, the supply, where the dampers engage...). Some cannot help at all: they are
inactive on the outputs fitted (a flow meter's density when only the position is
fitted), or the free parameters already do what they would. The Lagrange-multiplier
(score) test finds them from one finite-difference column each, all in one batched
simulation: at the nominal optimum ``r``, freeing a constant with residual column
``j`` lowers the cost to first order by ``(a.r)^2 / |a|^2``, where ``a`` is ``j`` less
its projection on the nominal Jacobian (free parameters and initial states); ``a = 0``
means nothing new. The others go on to the screen (at most
:data:`CONSTANTS_SCREENED`, the largest first-order gains first), where they are
fitted like every named effect: on a switching model the first-order gain is a poor
judge of what a fit finds (on the pneumatic rig it ranks the piston's bore, whose fit
moves nothing, above chamber A's dead volume, whose fit halves the cost), so it only
orders and filters, it does not decide.

Reference: Rao's score test; in nonlinear least squares, e.g. Seber & Wild,
*Nonlinear Regression*, 1989, section 5.9.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pdmkit.models.mismatch._candidates import Effect
from pdmkit.models.mismatch._fit_problem import (
    FD_LARGE,
    _fd_jacobians,
    _fd_rows,
    _Job,
    _Problem,
    _Row,
)

__all__ = ["constant_gains", "promising_constants"]

#: constants passed on to the screen, at most (the largest first-order gains)
CONSTANTS_SCREENED = 12
#: a constant goes on only when freeing it removes at least this share of the nominal
#: cost to first order (below it, it does nothing the free parameters cannot do)
CONSTANT_MIN_GAIN = 1e-3
#: the second, smaller relative step of a constant's residual column (the first is
#: ``FD_LARGE``, which steps over the staircase of a fixed-step switching simulation)
FD_SMALL_CONSTANT = 1e-4


def constant_gains(
    problem: _Problem, nominal: _Job, constants: Sequence[Effect]
) -> np.ndarray:
    """First-order share of the nominal cost that freeing each constant removes.

    Returns an array aligned with ``constants``: 0 for a constant that does nothing
    the free parameters and initial states cannot do. Each column is taken at two
    steps (``FD_LARGE`` and :data:`FD_SMALL_CONSTANT`) and the smaller gain counts: a
    constant near a limit of its law (a ratio just below 1) is not linear over 1 %.
    """
    frows, steps, dx = _fd_rows(nominal, nominal.theta, nominal.x0)
    vals = nominal.values()
    nominal_values = np.array([e.opt("nominal") for e in constants])
    rels = (FD_LARGE, FD_SMALL_CONSTANT)
    crows = [
        (_Row((e,)), {**vals, f"{e.key}.value": v * (1.0 + rel)}, nominal.x0)
        for rel in rels
        for e, v in zip(constants, nominal_values, strict=True)
    ]
    R = problem.residuals(problem.simulate(frows + crows))
    R = np.where(np.isfinite(R), R, 0.0)
    r, J, Jx = _fd_jacobians(R, 0, nominal, steps, dx)
    A = _nominal_jacobian(J, Jx)
    n, cost = len(constants), max(float(r @ r), 1e-300)
    gains = []
    for i, rel in enumerate(rels):
        d = rel * nominal_values
        C = (R[len(frows) + i * n : len(frows) + (i + 1) * n] - r[None]).T / d[None]
        coef, *_ = np.linalg.lstsq(A, C, rcond=1e-10)
        a = C - A @ coef
        norm2 = np.sum(a**2, axis=0)
        with np.errstate(all="ignore"):
            gain = (a.T @ r) ** 2 / norm2 / cost
        usable = (norm2 > 1e-12 * np.sum(C**2, axis=0)) & np.isfinite(gain)
        gains.append(np.where(usable, gain, 0.0))
    return np.minimum(*gains)


def _nominal_jacobian(J: np.ndarray, Jx: np.ndarray | None) -> np.ndarray:
    """The nominal fit's Jacobian in its parameters and every piece's initial state."""
    blocks = [J]
    if Jx is not None:  # each piece's initial state acts on its own rows only
        K, m_k, nx = Jx.shape
        for k in range(K):
            block = np.zeros((J.shape[0], nx))
            block[k * m_k : (k + 1) * m_k] = Jx[k]
            blocks.append(block)
    return np.hstack(blocks)


def promising_constants(
    problem: _Problem, nominal: _Job, constants: Sequence[Effect]
) -> list[Effect]:
    """The constants worth a fit, the most promising first (see the module)."""
    if not constants:
        return []
    gain = constant_gains(problem, nominal, constants)
    order = np.argsort(-gain)
    return [
        constants[i] for i in order[:CONSTANTS_SCREENED] if gain[i] >= CONSTANT_MIN_GAIN
    ]
