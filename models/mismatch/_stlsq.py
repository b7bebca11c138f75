"""Sequentially thresholded least squares (STLSQ) of a linearised fit, along a path.

The selection step of the data-driven fallback of mismatch discovery
(:mod:`pdmkit.models.mismatch._sparse`): SINDy's thresholding (Brunton, Proctor & Kutz,
PNAS 2016) applied to ``r + J d``, the residual linearised in the term coefficients.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["stlsq_path"]


def stlsq_path(
    r: np.ndarray,
    J: np.ndarray,
    term_cols: Sequence[int],
    c0: np.ndarray,
    n_lambda: int = 14,
    ridge: float = 1e-8,
) -> list[tuple[tuple[int, ...], np.ndarray, float]]:
    """Sequentially thresholded least squares along a path of thresholds.

    Solves ``min ||r + J d||`` where the columns ``term_cols`` are term coefficients
    (current values ``c0``; a dropped term is set to 0) and the other columns are
    unpenalised. For each threshold ``lam`` (relative to the largest coefficient of the
    full solution) terms with ``|c| < lam`` are dropped and the rest refitted until the
    set stops changing (Brunton et al. 2016).

    Returns
    -------
    list of (active term positions, full step ``d``, linearised cost)
        One entry per distinct active set, empty set included.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._stlsq import stlsq_path
    >>> rng = np.random.default_rng(0)
    >>> J = rng.normal(size=(200, 5))
    >>> r = -(J @ np.array([1.0, 0.0, 0.0, 2.0, 0.0])) + 0.01 * rng.normal(size=200)
    >>> path = stlsq_path(r, J, [1, 2, 3, 4], np.zeros(4))
    >>> best = min(path, key=lambda p: p[2] + 5 * len(p[0]))
    >>> best[0], np.abs(best[1]).round(2).tolist()
    ((2,), [1.0, 0.0, 0.0, 2.0, 0.0])
    """
    term_cols = list(term_cols)
    n = J.shape[1]
    other = [i for i in range(n) if i not in term_cols]
    norms = np.linalg.norm(J, axis=0)
    norms = np.where(norms > 0, norms, 1.0)

    def solve(active: Sequence[int]) -> tuple[np.ndarray, float]:
        cols_t = [term_cols[a] for a in active]
        inactive = [term_cols[a] for a in range(len(term_cols)) if a not in active]
        d = np.zeros(n)
        for a in range(len(term_cols)):
            if a not in active:
                d[term_cols[a]] = -c0[a]
        rr = r + J[:, inactive] @ d[inactive] if inactive else r.copy()
        cols = other + cols_t
        if cols:
            A = J[:, cols] / norms[cols]
            AtA = A.T @ A
            AtA[np.diag_indices_from(AtA)] += ridge * (np.trace(AtA) / len(cols) + 1e-300)
            z = np.linalg.solve(AtA, -(A.T @ rr))
            d[cols] = z / norms[cols]
            res = rr + A @ z
        else:
            res = rr
        return d, 0.5 * float(np.dot(res, res))

    d_full, cost_full = solve(range(len(term_cols)))
    c_full = c0 + d_full[term_cols]
    top = float(np.max(np.abs(c_full))) if len(term_cols) else 0.0
    out: dict[tuple[int, ...], tuple[np.ndarray, float]] = {
        tuple(range(len(term_cols))): (d_full, cost_full)
    }
    for lam in top * np.geomspace(1e-3, 0.9, n_lambda):
        active = tuple(range(len(term_cols)))
        d = d_full
        for _ in range(12):
            c = c0 + d[term_cols]
            new = tuple(a for a in active if abs(c[a]) >= lam)
            if new == active:
                break
            active = new
            d, cost = solve(active)
            out.setdefault(active, (d, cost))
    out.setdefault((), solve(()))
    return [(k, v[0], v[1]) for k, v in out.items()]
