"""Subspace identification of state-space models (N4SID family, PO-MOESP variant).

:func:`n4sid` estimates ``x(t+1) = A x + B u + K e``, ``y = C x + D u + e`` for any
number of inputs and outputs. The column space of the extended observability matrix
comes from the SVD of the past-output-instrumented projection (PO-MOESP, Verhaegen
1994; Verhaegen & Verdult, *Filtering and System Identification*, 2007, sec. 9.6),
computed with one RQ factorisation of the block-Hankel data matrix. ``A`` and ``C``
follow by the shift invariance of that matrix; ``B``, ``D`` and the initial state by
linear least squares on the simulated output; the Kalman gain ``K`` (optional) by
minimising the one-step prediction error.

Long noisy records can give an ``A`` with poles outside the unit circle at orders above
the true one (noise directions of the subspace); their simulation overflows. Such poles
are reflected into the unit circle (``z -> 1 / conj(z)``, the same magnitude response
shape) before ``B`` and ``D`` are estimated, and the model says so in
``info["stabilised_poles"]`` and a :class:`~pdmkit.errors.ConvergenceWarning`.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import numpy as np
from scipy import linalg, optimize

from pdmkit.errors import ConvergenceWarning, DataError, ModelError
from pdmkit.models.ident._model import IdentifiedModel, _as_signal, _check_fs, _check_order
from pdmkit.models.ident._statespace import _states, ss_predict

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["n4sid", "stabilise_matrix"]


def _hankel(x: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """Block Hankel: block row r holds x[r : r + cols].T."""
    return np.vstack([x[r : r + cols].T for r in range(rows)])


def _svd(M: np.ndarray):
    """Thin SVD; LAPACK's divide-and-conquer first, the QR-iteration driver if it fails."""
    try:
        return linalg.svd(M, full_matrices=False)
    except (np.linalg.LinAlgError, ValueError):
        return linalg.svd(M, full_matrices=False, lapack_driver="gesvd")


def stabilise_matrix(A: np.ndarray) -> tuple[np.ndarray, int]:
    """``A`` with its eigenvalues outside the unit circle reflected to ``1 / conj``.

    Conjugate pairs stay pairs, so the result is real. Returns ``(A_stable, count)``
    with the number of eigenvalues moved. A defective (non-diagonalisable) ``A`` is
    scaled into the circle instead.

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[1.2, 0.0], [0.0, 0.5]])
    >>> As, k = stabilise_matrix(A)
    >>> np.round(np.sort(np.linalg.eigvals(As)), 4), k
    (array([0.5   , 0.8333]), 1)
    """
    A = np.asarray(A, dtype=float)
    if A.size == 0:
        return A, 0
    lam, V = linalg.eig(A)
    out = np.abs(lam) >= 1.0
    if not out.any():
        return A, 0
    if np.linalg.cond(V) < 1e10:
        lam = lam.copy()
        lam[out] = 1.0 / np.conj(lam[out])
        lam[out] *= np.minimum(1.0, 0.9999 / np.abs(lam[out]))
        As = np.real(V @ np.diag(lam) @ np.linalg.inv(V))
    else:
        As = A * (0.9999 / np.max(np.abs(lam)))
    return As, int(out.sum())


def _bd_x0(A, C, u, y):
    """Least squares for B, D, x0 given A, C (output linear in them)."""
    n, l, m = A.shape[0], C.shape[0], u.shape[1]
    N = y.shape[0]
    cols = []
    eye = np.eye(n)
    zero_u = np.zeros((N, 1))
    for a in range(n):  # x0
        cols.append(_states(A, np.zeros((n, 1)), zero_u, eye[a]) @ C.T)
    for k in range(m):  # B[:, k]
        for a in range(n):
            cols.append(_states(A, eye[:, a : a + 1], u[:, k : k + 1]) @ C.T)
    for k in range(m):  # D[:, k]
        for i in range(l):
            c = np.zeros((N, l))
            c[:, i] = u[:, k]
            cols.append(c)
    phi = np.stack([c.reshape(-1) for c in cols], axis=1)  # (N*l, p), row-major (t, out)
    if not np.all(np.isfinite(phi)):
        raise ModelError(
            "n4sid: the state sequence overflowed (an unstable A); lower nx or pass "
            "stabilize=True."
        )
    try:
        theta = np.linalg.lstsq(phi, y.reshape(-1), rcond=None)[0]
    except np.linalg.LinAlgError:  # badly conditioned: solve through the QR route
        theta = linalg.lstsq(phi, y.reshape(-1), lapack_driver="gelsy")[0]
    x0 = theta[:n]
    B = theta[n : n + n * m].reshape(m, n).T
    D = theta[n + n * m :].reshape(m, l).T
    return B, D, x0


def _n4sid_signals(u, y, nx: int, horizon):
    """Checked ``(N, m)`` / ``(N, l)`` signals and the Hankel horizon ``s``."""
    u2 = u.reshape(u.shape[0], -1)
    y2 = y.reshape(y.shape[0], -1)
    if u2.shape[0] != y2.shape[0]:
        raise DataError(f"u has {u2.shape[0]} samples but y has {y2.shape[0]}.")
    N, m = u2.shape
    l = y2.shape[1]
    s = max(2 * nx, 10) if horizon is None else _check_order(horizon, "horizon", 1)
    s = max(s, nx // l + 1)
    j = N - 2 * s + 1
    if j < 2 * s * (m + l):
        raise DataError(
            f"y has {N} samples; n4sid with horizon {s} needs at least "
            f"{2 * s * (m + l) + 2 * s} (lower horizon or nx)."
        )
    return u2, y2, s


def _standardise(x2: np.ndarray):
    """``(x - mean) / std`` per channel (std 0 -> 1); returns ``(xs, mean, std)``."""
    xo = x2.mean(axis=0)
    sx = np.where(x2.std(axis=0) > 0, x2.std(axis=0), 1.0)
    return (x2 - xo) / sx, xo, sx


def _projection_factor(us: np.ndarray, ys: np.ndarray, s: int) -> np.ndarray:
    """The block ``L32`` of the RQ factor of the Hankel data (PO-MOESP projection)."""
    m, l = us.shape[1], ys.shape[1]
    j = us.shape[0] - 2 * s + 1
    U = _hankel(us, 2 * s, j)
    Y = _hankel(ys, 2 * s, j)
    Up, Uf = U[: s * m], U[s * m :]
    Yp, Yf = Y[: s * l], Y[s * l :]
    H = np.vstack([Uf, Up, Yp, Yf]) / np.sqrt(j)
    R = linalg.qr(H.T, mode="r", overwrite_a=True)[0]
    L = R[: H.shape[0]].T
    r1, r2 = s * m, s * (m + l)
    L32 = L[r1 + r2 :, r1 : r1 + r2]
    if not np.all(np.isfinite(L32)):
        raise DataError(
            "n4sid: the data matrix has non-finite entries; check u and y for overflow."
        )
    return L32


def _a_and_c(L32: np.ndarray, nx: int, l: int, stabilize: bool):
    """``A, C`` by the shift invariance of the observability matrix; ``S``, poles moved."""
    Uo, S, _ = _svd(L32)
    gamma = Uo[:, :nx] * np.sqrt(S[:nx])
    C = gamma[:l]
    A = linalg.lstsq(gamma[:-l], gamma[l:], lapack_driver="gelsy")[0]
    n_moved = 0
    if stabilize:
        A, n_moved = stabilise_matrix(A)
        if n_moved:
            warnings.warn(
                f"n4sid: {n_moved} of the {nx} poles of the nx={nx} model lay on or "
                "outside the unit circle and were reflected into it; a lower nx (or "
                "an OE model) likely describes the data better.",
                ConvergenceWarning,
                stacklevel=3,
            )
    return A, C, S, n_moved


def _kalman_gain(A, B, C, D, us, ys, max_nfev: int, max_samples_k: int):
    """The gain ``K`` minimising the one-step prediction error; returns ``(K, nfev)``."""
    nx, l = A.shape[0], C.shape[0]
    # the gain is fitted on at most the last `max_samples_k` samples: plenty for
    # n * l numbers, and it keeps long records fast
    uk, yk = us[-max_samples_k:], ys[-max_samples_k:]

    def resid(k):
        Km = k.reshape(nx, l)
        if np.max(np.abs(linalg.eigvals(A - Km @ C))) >= 1.0:
            return np.full(yk.size, 1e3)
        return (yk - ss_predict(A, B, C, D, Km, uk, yk, 1)).ravel()

    res = optimize.least_squares(
        resid, np.zeros(nx * l), method="lm", max_nfev=max_nfev * (nx * l + 1)
    )
    if res.status == 0:
        warnings.warn(
            "n4sid: the Kalman-gain fit did not converge; K may be poor "
            "(simulation is unaffected).",
            ConvergenceWarning,
            stacklevel=3,
        )
    return res.x.reshape(nx, l), res.nfev


def n4sid(
    u: ArrayLike,
    y: ArrayLike,
    nx: int,
    *,
    fs: float = 1.0,
    horizon: int | None = None,
    noise_model: bool = True,
    max_nfev: int = 20,
    max_samples_k: int = 20_000,
    stabilize: bool = True,
) -> IdentifiedModel:
    """State-space model of order ``nx`` by subspace identification (PO-MOESP).

    Parameters
    ----------
    u : array_like, shape (N,) or (N, n_inputs)
    y : array_like, shape (N,) or (N, n_outputs)
        Means are removed and every channel scaled to unit variance internally.
    nx : int
        State dimension (two per vibration mode).
    fs : float, default 1.0
        Sampling rate in Hz.
    horizon : int, optional
        Past and future block rows of the Hankel matrices (default
        ``max(2 * nx, 10)``); must exceed ``nx / n_outputs``.
    noise_model : bool, default True
        Also fit the Kalman gain ``K`` (one-step prediction-error fit); without it
        the model is output-error type (``K = None``).
    max_nfev : int, default 20
        Cap on Levenberg-Marquardt iterations for ``K`` (times ``nx * n_outputs + 1``
        evaluations).
    max_samples_k : int, default 20000
        ``K`` is fitted on the last this many samples.
    stabilize : bool, default True
        Reflect poles of ``A`` that lie on or outside the unit circle into it (with a
        :class:`~pdmkit.errors.ConvergenceWarning`; their number in
        ``info["stabilised_poles"]``). Without it an unstable ``A`` is kept, and a
        record long enough to overflow its simulation is a ``ModelError``.

    Returns
    -------
    IdentifiedModel
        With ``ss = (A, B, C, D)``, ``K``, and ``info["singular_values"]`` (their
        gap shows the order).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=4000)
    >>> y = signal.lfilter([0, 0.5, 0.2], [1, -1.5, 0.8], u) + 0.01 * rng.normal(size=4000)
    >>> m = n4sid(u, y, 2, noise_model=False)
    >>> np.round(np.sort_complex(m.poles), 3)
    array([0.75-0.487j, 0.75+0.487j])
    """
    fs = _check_fs(fs)
    nx = _check_order(nx, "nx", 1)
    u = _as_signal(u, "u", allow_2d=True)
    y = _as_signal(y, "y", allow_2d=True)
    u2, y2, s = _n4sid_signals(u, y, nx, horizon)
    N, m = u2.shape
    l = y2.shape[1]
    us, uo, su = _standardise(u2)
    ys, yo, sy = _standardise(y2)
    A, C, S, n_moved = _a_and_c(_projection_factor(us, ys, s), nx, l, stabilize)
    B, D, _ = _bd_x0(A, C, us, ys)

    K = None
    info = {"singular_values": S.tolist(), "horizon": s, "stabilised_poles": n_moved}
    if noise_model:
        K, info["nfev_K"] = _kalman_gain(A, B, C, D, us, ys, max_nfev, max_samples_k)

    # undo the scaling: u_s = (u - uo)/su, y = sy * y_s + yo
    B_r = B / su[None, :]
    C_r = C * sy[:, None]
    D_r = (D * sy[:, None]) / su[None, :]
    K_r = None if K is None else K / sy[None, :]
    squeeze_u = u.ndim == 1
    squeeze_y = y.ndim == 1
    n_par = nx * (m + l) + l * m + (nx * l if noise_model else 0)
    model = IdentifiedModel(
        "n4sid",
        fs,
        {"nx": nx},
        ss=(A, B_r, C_r, D_r),
        K=K_r,
        n_params=n_par,
        n_samples=N,
        u_offset=float(uo[0]) if squeeze_u else uo,
        y_offset=float(yo[0]) if squeeze_y else yo,
        info=info,
    )
    e = model.prediction_errors(u, y)
    model.residuals = e
    skip = min(N // 10, 3 * s)
    model.noise_variance = float(np.mean(np.asarray(e)[skip:] ** 2))
    model.fit_percent = model.compare(u, y, None)
    return model
