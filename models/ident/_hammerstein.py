"""Hammerstein-Wiener models: static nonlinearities around a discrete linear block.

``u -> f(u) -> B(q)/F(q) -> g(.) -> y``: an input nonlinearity ``f`` (actuator: dead
zone, saturation, polynomial, piecewise linear), a linear output-error block with
``nb`` numerator and ``nf`` denominator coefficients and an input delay of ``nk``
samples, and an output nonlinearity ``g`` (sensor or end stops). Voronin's thesis
(sections 5.2.1, 8.2.1) identified such a model for every recording of the pneumatic
piston with MATLAB's ``nlhw`` and used the coefficients as condition indicators; the
classifier did not exceed 40 % accuracy. :class:`HammersteinWiener` fits all blocks
together by simulation-error minimisation (:func:`scipy.optimize.least_squares`), so the
fitted coefficients can be compared with the thesis's experience
(``benchmarks/hw_vs_signal.py``).

Gain ambiguity: a gain can move between the blocks without changing the output. The
nonlinearities are therefore normalised (unit slope outside a dead zone, inside a
saturation, and in the linear term of a polynomial); only the piecewise-linear one is
free-form, and the linear block's DC gain is then fixed at 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.optimize as sopt
import scipy.signal as ss
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError, ModelError, NotFittedError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = [
    "DeadZone",
    "HammersteinWiener",
    "Identity",
    "PiecewiseLinear",
    "Polynomial",
    "Saturation",
    "nonlinearity",
]


# ----------------------------------------------------------------------------- blocks
class Identity:
    """No nonlinearity: ``f(x) = x``.

    Examples
    --------
    >>> from pdmkit.models.ident import Identity
    >>> Identity()(2.0, [])
    2.0
    """

    name = "identity"
    param_names: tuple = ()

    def __call__(self, x, theta):
        return x

    def initial(self, x: np.ndarray) -> np.ndarray:
        return np.array([])

    def bounds(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.array([]), np.array([])

    def starts(self, x: np.ndarray) -> list[np.ndarray]:
        return [self.initial(x)]


class DeadZone(Identity):
    """Dead zone: ``0`` on ``[lower, upper]``, unit slope outside (MATLAB ``deadzone``).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ident import DeadZone
    >>> DeadZone()(np.array([-1.0, 0.1, 1.0]), [-0.2, 0.3]).tolist()
    [-0.8, 0.0, 0.7]
    """

    name = "deadzone"
    param_names = ("lower", "upper")

    def __call__(self, x, theta):
        lo, hi = min(theta[0], theta[1]), max(theta[0], theta[1])
        return np.where(x > hi, x - hi, np.where(x < lo, x - lo, 0.0))

    def initial(self, x: np.ndarray) -> np.ndarray:
        s = np.std(x)
        return np.array([-0.1 * s, 0.1 * s])

    def bounds(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r = np.max(np.abs(x))
        return np.array([-r, -r]), np.array([r, r])

    def starts(self, x: np.ndarray) -> list[np.ndarray]:
        s = np.std(x)
        return [np.array([-k * s, k * s]) for k in (0.05, 0.3, 0.8)]


class Saturation(Identity):
    """Saturation: ``clip(x, lower, upper)`` (MATLAB ``saturation``; end stops).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ident import Saturation
    >>> Saturation()(np.array([-2.0, 0.5, 2.0]), [-1.0, 1.0]).tolist()
    [-1.0, 0.5, 1.0]
    """

    name = "saturation"
    param_names = ("lower", "upper")

    def __call__(self, x, theta):
        lo, hi = min(theta[0], theta[1]), max(theta[0], theta[1])
        return np.clip(x, lo, hi)

    def initial(self, x: np.ndarray) -> np.ndarray:
        return np.quantile(x, [0.02, 0.98])

    def bounds(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = np.min(x), np.max(x)
        pad = 2 * (hi - lo) + 1e-12
        return np.array([lo - pad, lo - pad]), np.array([hi + pad, hi + pad])

    def starts(self, x: np.ndarray) -> list[np.ndarray]:
        return [np.quantile(x, [q, 1 - q]) for q in (0.02, 0.15)]


class Polynomial(Identity):
    """Polynomial ``x + c2 x^2 + ... + cd x^d`` (linear coefficient fixed at 1).

    Parameters
    ----------
    degree : int, default 3

    Examples
    --------
    >>> from pdmkit.models.ident import Polynomial
    >>> Polynomial(3)(2.0, [0.5, 0.1])
    4.8
    """

    name = "polynomial"

    def __init__(self, degree: int = 3):
        if int(degree) < 2:
            raise ModelError(f"Polynomial degree must be >= 2; got {degree!r}.")
        self.degree = int(degree)
        self.param_names = tuple(f"c{k}" for k in range(2, self.degree + 1))

    def __call__(self, x, theta):
        out = x
        for k, c in enumerate(theta, start=2):
            out = out + c * x**k
        return out

    def initial(self, x: np.ndarray) -> np.ndarray:
        return np.zeros(self.degree - 1)

    def bounds(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = self.degree - 1
        return np.full(n, -np.inf), np.full(n, np.inf)

    def starts(self, x: np.ndarray) -> list[np.ndarray]:
        return [self.initial(x)]


class PiecewiseLinear(Identity):
    """Piecewise-linear map through ``n_breakpoints`` points at the data's quantiles.

    The breakpoints' abscissae are fixed at quantiles of the signal seen in ``fit``;
    the ordinates are fitted (linear extrapolation outside).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ident import PiecewiseLinear
    >>> pwl = PiecewiseLinear(3)
    >>> pwl.knots_ = np.array([-1.0, 0.0, 1.0])
    >>> pwl(np.array([-2.0, 0.5]), [-1.0, 0.0, 2.0]).tolist()
    [-2.0, 1.0]
    """

    name = "piecewise"

    def __init__(self, n_breakpoints: int = 5):
        if int(n_breakpoints) < 2:
            raise ModelError(f"n_breakpoints must be >= 2; got {n_breakpoints!r}.")
        self.n_breakpoints = int(n_breakpoints)
        self.param_names = tuple(f"y{k}" for k in range(self.n_breakpoints))

    def __call__(self, x, theta):
        xk, yk = self.knots_, np.asarray(theta, float)
        out = np.interp(x, xk, yk)
        lo_s = (yk[1] - yk[0]) / (xk[1] - xk[0])
        hi_s = (yk[-1] - yk[-2]) / (xk[-1] - xk[-2])
        out = np.where(x < xk[0], yk[0] + lo_s * (x - xk[0]), out)
        return np.where(x > xk[-1], yk[-1] + hi_s * (x - xk[-1]), out)

    def initial(self, x: np.ndarray) -> np.ndarray:
        q = np.linspace(0.02, 0.98, self.n_breakpoints)
        knots = np.unique(np.quantile(x, q))
        if knots.size < self.n_breakpoints:
            knots = np.linspace(np.min(x), np.max(x) + 1e-9, self.n_breakpoints)
        self.knots_ = knots
        return knots.copy()

    def bounds(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = self.n_breakpoints
        return np.full(n, -np.inf), np.full(n, np.inf)

    def starts(self, x: np.ndarray) -> list[np.ndarray]:
        return [self.initial(x)]


_NL = {
    "identity": Identity,
    "none": Identity,
    "deadzone": DeadZone,
    "saturation": Saturation,
    "polynomial": Polynomial,
    "piecewise": PiecewiseLinear,
}


def nonlinearity(spec: str | Identity | None, which: str = "nonlinearity") -> Identity:
    """The static nonlinearity block a Hammerstein-Wiener model uses for ``spec``.

    Parameters
    ----------
    spec : {"saturation", "deadzone", "piecewise", "polynomial", "identity"}, block or None
        A name of the built-in blocks, a block object, or None (identity).
    which : str
        The parameter's name in error messages.

    Examples
    --------
    >>> from pdmkit.models import nonlinearity
    >>> nonlinearity("saturation").param_names
    ('lower', 'upper')
    """
    if spec is None:
        return Identity()
    if isinstance(spec, str):
        if spec not in _NL:
            raise ModelError(
                f"{which} must be one of {sorted(_NL)} or a nonlinearity object; got "
                f"{spec!r}."
            )
        return _NL[spec]()
    if isinstance(spec, Identity):
        return spec
    raise ModelError(f"{which} must be a string or a nonlinearity object; got {spec!r}.")


def _as_records(x, name: str) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{name} must be a numeric array.") from exc
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] < 10:
        raise DataError(
            f"{name} must be (n_samples,) or (n_records, n_samples) with >= 10 samples; "
            f"got shape {np.shape(x)}."
        )
    if not np.all(np.isfinite(arr)):
        raise DataError(f"{name} holds NaN/inf values.")
    return arr


def _inside(theta, lo, hi):
    """Clip a start strictly inside finite bounds."""
    pad = 1e-9 * (1 + np.abs(theta))
    lo_in = np.where(np.isfinite(lo), lo + pad, -np.inf)
    hi_in = np.where(np.isfinite(hi), hi - pad, np.inf)
    return np.clip(theta, lo_in, hi_in)


# ----------------------------------------------------------------------------- model
@dataclass
class _Layout:
    n_in: int
    nb: int
    nf: int
    n_out: int

    def split(self, theta):
        i = 0
        th_in = theta[i : i + self.n_in]
        i += self.n_in
        b = theta[i : i + self.nb]
        i += self.nb
        f = theta[i : i + self.nf]
        i += self.nf
        return th_in, b, f, theta[i : i + self.n_out]


class HammersteinWiener(BaseEstimator):
    """Hammerstein-Wiener model fitted by simulation-error minimisation.

    Parameters
    ----------
    input_nl, output_nl : str or nonlinearity, default "deadzone" / None
        ``"deadzone"``, ``"saturation"``, ``"polynomial"``, ``"piecewise"``,
        ``"identity"`` (or None), or an instance (:class:`DeadZone`,
        :class:`Saturation`, :class:`Polynomial`, :class:`PiecewiseLinear`).
    nb, nf, nk : int, default 2, 2, 1
        Numerator coefficients, denominator order and input delay (samples) of the
        linear block ``B(q)/F(q)``.
    initial : {"zero", "steady"}, default "zero"
        Initial state of the linear block: zero, or the steady state of the first
        (transformed) input sample, for records that start at rest under their first
        input (a machine waiting for its command).
    max_nfev : int
        Evaluation limit of the optimiser's run from a start.
    screen_nfev, n_refine : int, default 40, 2
        Every start first gets ``screen_nfev`` evaluations; the ``n_refine`` with the
        lowest cost then run on (up to ``max_nfev`` more). On pneumatic-twin records
        this found the same or lower costs as running every start to the end, 2-3
        times faster (``screen_nfev=max_nfev`` restores that).

    Attributes
    ----------
    b_, f_ : ndarray
        Linear block ``B = b_0 + b_1 q^-1 + ...`` (after the delay) and
        ``F = 1 + f_1 q^-1 + ...``.
    input_params_, output_params_ : dict
        Nonlinearity parameters by name.
    coef_ : ndarray
        All parameters in one vector (names in ``coef_names_``): the condition
        indicators of Voronin's thesis.
    fit_percent_ : float
        ``100 (1 - ||y - y_sim|| / ||y - mean y||)`` on the training data.
    cost_ : float

    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.models.ident import HammersteinWiener, DeadZone
    >>> rng = np.random.default_rng(0)
    >>> u = np.repeat(rng.uniform(-1, 1, 200), 10)        # random steps
    >>> y = ss.lfilter([0, 0.3], [1, -0.7], DeadZone()(u, [-0.25, 0.25]))
    >>> hw = HammersteinWiener("deadzone", nb=1, nf=1, nk=1).fit(u, y)
    >>> np.round([hw.input_params_["lower"], hw.input_params_["upper"]], 3).tolist()
    [-0.25, 0.25]
    """

    def __init__(
        self,
        input_nl: str | Identity | None = "deadzone",
        output_nl: str | Identity | None = None,
        *,
        nb: int = 2,
        nf: int = 2,
        nk: int = 1,
        initial: str = "zero",
        max_nfev: int = 300,
        screen_nfev: int = 40,
        n_refine: int = 2,
    ):
        self.input_nl = input_nl
        self.output_nl = output_nl
        self.nb = nb
        self.nf = nf
        self.nk = nk
        self.initial = initial
        self.max_nfev = max_nfev
        self.screen_nfev = screen_nfev
        self.n_refine = n_refine

    # -------------------------------------------------------------- internals
    def _linear(self, w, b, f):
        num = np.concatenate([np.zeros(self.nk), b])
        den = np.concatenate([[1.0], f])
        if self.initial == "zero":
            return ss.lfilter(num, den, w, axis=-1)
        # the record starts at rest: filter state at steady state for the first input
        n = max(num.size, den.size)
        num, den = np.pad(num, (0, n - num.size)), np.pad(den, (0, n - den.size))
        if n == 1:
            return num[0] * w
        zi = ss.lfilter_zi(num, den)
        return ss.lfilter(num, den, w, axis=-1, zi=zi[None, :] * w[:, :1])[0]

    def _simulate(self, U, theta):
        th_in, b, f, th_out = self._layout.split(theta)
        if self._pwl_gain:  # free-form input map: fix the linear block's DC gain at 1
            b = b / (np.sum(b) / (1 + np.sum(f)) or 1.0)
        return self._out(self._linear(self._in(U, th_in), b, f), th_out)

    # -------------------------------------------------------------- API
    def fit(self, u: ArrayLike, y: ArrayLike) -> HammersteinWiener:
        """Fit all blocks to input ``u`` and output ``y`` (1-D, or one row per record).

        Returns
        -------
        self
        """
        U, Y = self._checked_records(u, y)
        self._in = nonlinearity(self.input_nl, "input_nl")
        self._out = nonlinearity(self.output_nl, "output_nl")
        self._pwl_gain = isinstance(self._in, PiecewiseLinear)
        ysc = np.std(Y) or 1.0
        starts, lo, hi = self._starts_and_bounds(U, Y)

        def resid(theta):
            _, _, f, _ = self._layout.split(theta)
            if self.nf and np.max(np.abs(np.roots(np.concatenate([[1.0], f])))) >= 1:
                return np.full(Y.size, 1e3)
            r = (self._simulate(U, theta) - Y).ravel() / ysc
            return np.where(np.isfinite(r), r, 1e3)

        best = self._best_of_starts(resid, starts, lo, hi)
        self._store_fit(best.x, U, Y)
        return self

    def _checked_records(self, u, y):
        """The options and the records ``(U, Y)``, one row per record, checked."""
        if self.initial not in ("zero", "steady"):
            raise ModelError(f"initial must be 'zero' or 'steady'; got {self.initial!r}.")
        U = _as_records(u, "u (input)")
        Y = _as_records(y, "y (output)")
        if U.shape != Y.shape:
            raise DataError(f"u and y must have the same shape; got {U.shape}, {Y.shape}.")
        for name in ("nb", "nf", "nk"):
            v = getattr(self, name)
            if (
                isinstance(v, bool)
                or not isinstance(v, int | np.integer)
                or v < (1 if name == "nb" else 0)
            ):
                raise ModelError(
                    f"{name} must be a non-negative integer (nb >= 1); got {v!r}."
                )
        return U, Y

    def _starts_and_bounds(self, U, Y):
        """Start vectors ``(linear, input, output)``, bounds; sets the parameter layout."""
        # linear start: ARX least squares on (u, y) -> F, B
        b0, f0 = self._arx_start(U, Y)
        in_starts = self._in.starts(U.ravel())
        lin_y = self._linear(self._in(U, in_starts[0]), b0, f0)
        out_starts = self._out.starts(lin_y.ravel()) if self.output_nl else [np.array([])]
        lo_in, hi_in = self._in.bounds(U.ravel())
        lo_out, hi_out = self._out.bounds(Y.ravel())
        self._layout = _Layout(len(in_starts[0]), self.nb, self.nf, len(out_starts[0]))
        lo = np.concatenate([lo_in, np.full(self.nb + self.nf, -np.inf), lo_out])
        hi = np.concatenate([hi_in, np.full(self.nb + self.nf, np.inf), hi_out])
        lin_starts = [(b0, f0)]
        if self.nf:  # plus slow real poles with the data's gain: escapes poor ARX starts
            gain = (np.ptp(Y) / (np.ptp(U) or 1.0)) or 1.0
            for p in (0.8, 0.95):
                f_p = np.real(np.poly(np.full(self.nf, p)))[1:]
                b_p = np.full(self.nb, gain * (1 + np.sum(f_p)) / self.nb)
                lin_starts.append((b_p, f_p))
        starts = [
            (ls, ti, to) for ls in lin_starts for ti in in_starts for to in out_starts
        ]
        return starts, lo, hi

    def _best_of_starts(self, resid, starts, lo, hi):
        """Screen every start briefly, run the ``n_refine`` best on; the best solution."""

        def solve(theta0, budget):
            return sopt.least_squares(
                resid, theta0, bounds=(lo, hi), max_nfev=budget, diff_step=1e-6
            )

        # every start gets a short run; the most promising ones run on to convergence
        screened = [
            solve(
                _inside(np.concatenate([th_in, b_s, f_s, th_out]), lo, hi),
                min(self.screen_nfev, self.max_nfev),
            )
            for (b_s, f_s), th_in, th_out in starts
        ]
        best = None
        for i in np.argsort([sol.cost for sol in screened])[: max(1, self.n_refine)]:
            sol = screened[i]
            if sol.status == 0:  # stopped by the screening budget: run on
                sol = solve(sol.x, self.max_nfev)
            if best is None or sol.cost < best.cost:
                best = sol
        return best

    def _store_fit(self, theta, U, Y):
        """The fitted attributes (blocks, parameters by name, fit) from ``theta``."""
        th_in, b, f, th_out = self._layout.split(theta)
        if self._pwl_gain:
            b = b / (np.sum(b) / (1 + np.sum(f)) or 1.0)
        self.theta_ = theta
        self.b_, self.f_ = b.copy(), f.copy()
        self.input_params_ = dict(zip(self._in.param_names, map(float, th_in), strict=True))
        self.output_params_ = dict(
            zip(self._out.param_names, map(float, th_out), strict=True)
        )
        for params in (self.input_params_, self.output_params_):
            if "lower" in params and params["lower"] > params["upper"]:
                params["lower"], params["upper"] = params["upper"], params["lower"]
        names = [f"in_{k}" for k in self._in.param_names]
        names += [f"b{i}" for i in range(self.nb)] + [f"f{i + 1}" for i in range(self.nf)]
        names += [f"out_{k}" for k in self._out.param_names]
        self.coef_names_ = names
        self.coef_ = np.concatenate(
            [
                list(self.input_params_.values()),
                self.b_,
                self.f_,
                list(self.output_params_.values()),
            ]
        )
        e = self._simulate(U, theta) - Y
        self.cost_ = float(np.mean(e**2))
        self.fit_percent_ = float(
            100 * (1 - np.linalg.norm(e) / np.linalg.norm(Y - Y.mean()))
        )

    def _arx_start(self, U, Y):
        nb, nf, nk = self.nb, self.nf, self.nk
        rows, rhs = [], []
        for u, y in zip(U, Y, strict=True):
            n0 = max(nf, nk + nb - 1)
            for t in range(n0, u.size):
                rows.append(
                    [-y[t - j] for j in range(1, nf + 1)]
                    + [u[t - nk - i] for i in range(nb)]
                )
                rhs.append(y[t])
        theta, *_ = np.linalg.lstsq(np.asarray(rows), np.asarray(rhs), rcond=None)
        f, b = theta[:nf], theta[nf:]
        if nf and np.max(np.abs(np.roots(np.concatenate([[1.0], f])))) >= 1:
            r = np.roots(np.concatenate([[1.0], f]))
            r = np.where(np.abs(r) >= 1, 0.95 * r / np.abs(r), r)
            f = np.real(np.poly(r))[1:]
        return b, f

    def predict(self, u: ArrayLike) -> np.ndarray:
        """Simulated output for input ``u`` (same shape as ``u``)."""
        if not hasattr(self, "theta_"):
            raise NotFittedError("HammersteinWiener is not fitted; call fit(u, y) first.")
        U = _as_records(u, "u (input)")
        out = self._simulate(U, self.theta_)
        return out[0] if np.ndim(u) == 1 else out

    @property
    def poles_(self) -> np.ndarray:
        """Poles of the linear block (z-plane)."""
        return np.roots(np.concatenate([[1.0], self.f_])) if self.nf else np.array([])

    def to_pandas(self) -> pd.Series:
        """All coefficients by name, with the fit percentage."""
        if not hasattr(self, "coef_"):
            raise NotFittedError("HammersteinWiener is not fitted; call fit(u, y) first.")
        return pd.Series(
            {
                **dict(zip(self.coef_names_, self.coef_, strict=True)),
                "fit_percent": self.fit_percent_,
            }
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """The fitted input nonlinearity on the input range; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        th_in = self._layout.split(self.theta_)[0]
        x = np.linspace(-1, 1, 201) * (max(abs(v) for v in th_in) * 3 if len(th_in) else 1)
        ax.plot(x, self._in(x, th_in))
        ax.set_xlabel("input")
        ax.set_ylabel("f(input)")
        return ax
