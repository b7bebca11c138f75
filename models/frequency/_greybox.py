"""Physical parameters fitted to measured FRFs with the S-Mobile paper's weighted error."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.optimize as sopt

from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency._frf import _DB, FRF

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["GreyBoxFit", "fit_frf_params"]


@dataclass
class GreyBoxFit:
    """Physical parameters fitted to FRFs by :func:`fit_frf_params`.

    Attributes
    ----------
    params : dict of str to float
        Fitted values.
    rms_db, rms_deg : float
        Coherence-weighted RMS magnitude (dB) and phase (degrees) error at the optimum.
    cost : float
        The minimised error (``rms_db**2 + (phase_weight * rms_phase_in_dB_units)**2``).
    freq, H, H_model, weight : ndarray
        The data, the fitted model's response and the weights used.
    success : bool


    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models import FRF, fit_frf_params
    >>> def spring_mass(omega, m, k):
    ...     return 1.0 / (k - m * omega**2 + 0.5j * omega)
    >>> f = np.linspace(0.5, 5, 50)
    >>> data = FRF(f, spring_mass(2 * np.pi * f, 1.0, 80.0))
    >>> fit = fit_frf_params(spring_mass, {"k": 50.0}, data, fixed={"m": 1.0})
    >>> round(fit.params["k"], 2), fit.rms_db < 1e-6
    (80.0, True)
    """

    params: dict
    rms_db: float
    rms_deg: float
    cost: float
    freq: np.ndarray
    H: np.ndarray
    H_model: np.ndarray
    weight: np.ndarray
    success: bool = True
    message: str = ""
    extra: dict = field(default_factory=dict)

    def to_pandas(self) -> pd.Series:
        """Fitted parameters and errors as a Series."""
        return pd.Series(
            {**self.params, "rms_db": self.rms_db, "rms_deg": self.rms_deg}, dtype=float
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """Measured and fitted magnitude; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        H = np.atleast_2d(self.H)
        for row in H:
            ax.semilogx(self.freq, _DB * np.log(np.abs(row) + 1e-300), ".", alpha=0.5)
        ax.semilogx(self.freq, _DB * np.log(np.abs(self.H_model) + 1e-300), "k-")
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("|H| (dB)")
        return ax


def fit_frf_params(
    frf_model: Callable[..., np.ndarray],
    params0: Mapping[str, float],
    frf: FRF,
    *,
    fixed: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    coherence_min: float = 0.0,
    phase_weight: float = 1.0,
    method: str = "least_squares",
    log_params: bool = True,
) -> GreyBoxFit:
    """Fit physical parameters of a model FRF to measured FRFs (S-Mobile paper, sec. 4).

    The error at each frequency is the complex-log difference ``ln(H_meas / H_model)``:
    its real part times 8.69 is the magnitude error in dB, its imaginary part the phase
    error (radians, wrapped to (-pi, pi], so no unwrapping is needed). Each frequency
    is weighted by the measurement's coherence (zero below ``coherence_min``), as the
    S-Mobile paper weights its RMS amplitude and phase errors by the coherence-dependent
    factor ``k_eval``; several rows (amplitudes) are fitted together.

    Parameters
    ----------
    frf_model : callable
        ``frf_model(omega, **params) -> complex array`` with ``omega`` in rad/s.
    params0 : dict of str to float
        Free parameters and their starting values.
    frf : FRF
        Measured FRF(s) (:func:`frf_estimate`).
    fixed : dict, optional
        Parameters passed to ``frf_model`` unchanged.
    bounds : dict of name -> (low, high), optional
        Bounds of the free parameters.
    coherence_min : float
        Frequencies with lower coherence get zero weight.
    phase_weight : float
        Weight of the phase error relative to the magnitude error (1: one radian counts
        as one neper, 8.69 dB).
    method : {"least_squares", "nelder-mead"}
        Trust-region least squares, or the Nelder-Mead simplex the S-Mobile paper uses.
    log_params : bool
        Optimise ``log(p)`` of positive parameters (scale-free; keeps them positive).

    Returns
    -------
    GreyBoxFit

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FRF, fit_frf_params
    >>> def msd(omega, m, c, k):
    ...     s = 1j * omega
    ...     return 1.0 / (m * s**2 + c * s + k)
    >>> f = np.linspace(0.5, 10, 100)
    >>> data = FRF(f, msd(2 * np.pi * f, 1.0, 2.0, 400.0))
    >>> fit = fit_frf_params(msd, {"c": 1.0, "k": 300.0}, data, fixed={"m": 1.0})
    >>> round(fit.params["c"], 3), round(fit.params["k"], 2)
    (2.0, 400.0)
    """
    if not isinstance(frf, FRF):
        raise DataError(f"frf must be an FRF (see frf_estimate); got {type(frf).__name__}.")
    names = list(params0)
    if not names:
        raise ModelError("params0 is empty; give at least one free parameter.")
    fixed = dict(fixed or {})
    p0, logm, lo, hi = _free_parameters(names, params0, bounds, log_params)
    H, wgt = _coherence_weights(frf, coherence_min)
    omega = frf.omega
    sw = np.sqrt(wgt / wgt.sum())

    def to_params(theta):
        v = np.where(logm, np.exp(np.clip(theta, -700, 700)), theta)
        return dict(zip(names, v.tolist(), strict=True))

    def model(theta):
        Hm = np.asarray(frf_model(omega, **to_params(theta), **fixed), dtype=complex)
        if Hm.shape != omega.shape:
            raise ModelError(
                f"frf_model must return one complex value per frequency {omega.shape}; "
                f"got shape {Hm.shape}."
            )
        return Hm

    def resid(theta):
        Hm = model(theta)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.log(np.where(wgt > 0, H, 1.0) / Hm[None, :])
        d = np.where(np.isfinite(d), d, 50.0)
        r = np.concatenate([(sw * d.real).ravel(), (sw * phase_weight * d.imag).ravel()])
        return r

    theta0 = np.where(logm, np.log(np.where(logm, p0, 1.0)), p0)
    theta, ok, msg = _minimise(resid, theta0, lo, hi, bool(bounds), method)
    Hm = model(theta)
    d = np.log(np.where(wgt > 0, H, 1.0) / Hm[None, :])
    ws = wgt.sum()
    rms_db = float(np.sqrt(np.sum(wgt * (_DB * d.real) ** 2) / ws))
    rms_deg = float(np.sqrt(np.sum(wgt * np.degrees(d.imag) ** 2) / ws))
    return GreyBoxFit(
        to_params(theta),
        rms_db,
        rms_deg,
        float(np.sum(resid(theta) ** 2)),
        frf.freq,
        frf.H,
        Hm,
        wgt,
        ok,
        msg,
    )


def _free_parameters(names, params0, bounds, log_params):
    """Starts, which run on a log scale, and the bounds in the optimiser's units."""
    p0 = np.array([float(params0[k]) for k in names])
    logm = np.array([log_params and v > 0 for v in p0])
    lo = np.full(p0.size, -np.inf)
    hi = np.full(p0.size, np.inf)
    for i, k in enumerate(names):
        if bounds and k in bounds:
            lo[i], hi[i] = bounds[k]
            if logm[i]:
                lo[i] = np.log(lo[i]) if lo[i] > 0 else -np.inf
                hi[i] = np.log(hi[i]) if np.isfinite(hi[i]) else np.inf
    return p0, logm, lo, hi


def _coherence_weights(frf, coherence_min):
    """The FRF rows and their weights: the coherence, 0 below ``coherence_min``."""
    H = np.atleast_2d(frf.H)
    coh = np.broadcast_to(np.atleast_2d(frf.coherence), H.shape)
    wgt = np.where(coh >= coherence_min, coh, 0.0) * (np.abs(H) > 0)
    if not np.any(wgt > 0):
        raise DataError(
            f"no frequency has coherence >= coherence_min={coherence_min}; lower it."
        )
    return H, wgt


def _minimise(resid, theta0, lo, hi, bounded, method):
    """Least squares or Nelder-Mead on ``resid``; ``(theta, success, message)``."""
    if method == "least_squares":
        sol = sopt.least_squares(resid, theta0, bounds=(lo, hi), x_scale="jac")
        return sol.x, bool(sol.success), str(sol.message)
    if method == "nelder-mead":
        bnds = list(zip(lo, hi, strict=True)) if bounded else None
        sol = sopt.minimize(
            lambda t: float(np.sum(resid(t) ** 2)),
            theta0,
            method="Nelder-Mead",
            bounds=bnds,
            options={"xatol": 1e-8, "fatol": 1e-12, "maxiter": 4000 * theta0.size},
        )
        return sol.x, bool(sol.success), str(sol.message)
    raise ModelError(f"method must be 'least_squares' or 'nelder-mead'; got {method!r}.")
