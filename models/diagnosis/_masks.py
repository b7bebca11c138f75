"""Diagnosis from tracked quantities: diagnostic masks and the binary diagnostic matrix.

A *diagnostic mask* is a tolerance band on one tracked quantity (a natural frequency,
a damping ratio, a residual): the quantity is a symptom when it leaves the band. As in
the rotor-diagnostics monograph (sec. 3.4), false alarms are suppressed by an *alarm
delay* (the quantity must stay outside for ``delay`` consecutive samples before the alarm
rises) and *hysteresis* (once raised, the alarm clears only when the quantity is back
inside the band narrowed by ``hysteresis`` for ``delay`` samples). A mask is *static*
(limits given) or *self-tuned* from a history window of healthy operation (centre and
spread estimated robustly).

The *binary diagnostic matrix* (the monograph's sec. 2.8.2) maps a vector of binary
symptoms to a fault; every fault must have its own symptom vector, or the faults cannot
be told apart.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError, ModelError, NotFittedError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["DiagnosticMask", "DiagnosticMatrix", "MaskResult"]


@dataclass(eq=False)
class MaskResult:
    """Alarm state of a mask over a record.

    Attributes
    ----------
    time : ndarray
    value : ndarray
        The monitored quantity.
    lower, upper : float
        The band.
    symptom : ndarray of int
        Per sample: +1 above the band, -1 below, 0 inside (before delay/hysteresis).
    alarm : ndarray of bool
        The alarm after delay and hysteresis.
    onsets : ndarray of int
        Sample indices where the alarm rises.

    Examples
    --------
    >>> import numpy as np
    >>> res = DiagnosticMask(upper=1.0, delay=1).evaluate(np.array([0, 2, 2, 2, 0, 0.0]))
    >>> res.alarm.tolist(), res.onsets.tolist(), res.any_alarm
    ([False, False, True, True, True, False], [2], True)
    """

    time: np.ndarray
    value: np.ndarray
    lower: float
    upper: float
    symptom: np.ndarray
    alarm: np.ndarray
    onsets: np.ndarray

    @property
    def any_alarm(self) -> bool:
        """True when the alarm rose at least once."""
        return bool(self.onsets.size)

    def to_pandas(self) -> pd.DataFrame:
        """Columns ``time``, ``value``, ``symptom``, ``alarm``."""
        return pd.DataFrame(
            {
                "time": self.time,
                "value": self.value,
                "symptom": self.symptom,
                "alarm": self.alarm,
            }
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """The quantity, the band and the alarm periods (shaded); returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3))
        ax.plot(self.time, self.value, lw=0.8, label="value")
        for lim in (self.lower, self.upper):
            if np.isfinite(lim):
                ax.axhline(lim, color="C3", ls="--", lw=1)
        if self.alarm.any():
            ax.fill_between(
                self.time,
                0,
                1,
                where=self.alarm,
                color="C3",
                alpha=0.15,
                transform=ax.get_xaxis_transform(),
                label="alarm",
            )
        ax.set_xlabel("time")
        ax.legend(loc="best", fontsize="small")
        return ax


class DiagnosticMask(BaseEstimator):
    """Tolerance band with alarm delay and hysteresis, static or self-tuned.

    Parameters
    ----------
    lower, upper : float, optional
        Static limits (None: unbounded on that side). Give neither to self-tune
        from a history window in :meth:`fit`.
    k : float, default 5.0
        Self-tuning: the band is ``centre +- k * spread`` with the median as centre
        and the scaled median absolute deviation (``1.4826 * MAD``, the standard
        deviation for Gaussian data) as spread.
    hysteresis : float, default 0.0
        Once raised, the alarm clears only inside ``[lower + h, upper - h]``; in the
        units of the quantity, or, for a self-tuned mask, in spreads when
        ``relative=True``.
    delay : int, default 0
        Samples the condition must hold before the alarm rises (and clears).
    relative : bool, default True
        Read ``hysteresis`` in spreads for self-tuned masks.

    Attributes
    ----------
    lower_, upper_ : float
        The band in use after :meth:`fit`.
    centre_, spread_ : float
        Self-tuned masks only (NaN for static ones).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> healthy = 50 + 0.1 * rng.normal(size=2000)
    >>> mask = DiagnosticMask(k=5, hysteresis=1, delay=20).fit(healthy)
    >>> x = np.r_[50 + 0.1 * rng.normal(size=500), 51 + 0.1 * rng.normal(size=500)]
    >>> res = mask.evaluate(x)
    >>> res.onsets.tolist()
    [520]
    """

    def __init__(
        self,
        lower: float | None = None,
        upper: float | None = None,
        *,
        k: float = 5.0,
        hysteresis: float = 0.0,
        delay: int = 0,
        relative: bool = True,
    ):
        self.lower = lower
        self.upper = upper
        self.k = k
        self.hysteresis = hysteresis
        self.delay = delay
        self.relative = relative

    def fit(self, history: ArrayLike | None = None) -> DiagnosticMask:
        """Set the band: the static limits, or self-tuned from ``history`` (healthy)."""
        if (
            isinstance(self.delay, bool)
            or not isinstance(self.delay, int | np.integer)
            or (self.delay < 0)
        ):
            raise ModelError(f"delay must be an integer >= 0 samples; got {self.delay!r}.")
        if float(self.hysteresis) < 0:
            raise ModelError(f"hysteresis must be >= 0; got {self.hysteresis!r}.")
        static = self.lower is not None or self.upper is not None
        if static:
            lo = -np.inf if self.lower is None else float(self.lower)
            hi = np.inf if self.upper is None else float(self.upper)
            if not lo < hi:
                raise ModelError(f"lower ({lo}) must be below upper ({hi}).")
            self.centre_, self.spread_ = float("nan"), float("nan")
            self.lower_, self.upper_ = lo, hi
            self.hysteresis_ = float(self.hysteresis)
            return self
        if history is None:
            raise ModelError(
                "DiagnosticMask has neither lower/upper limits nor a history to tune "
                "from: pass limits, or fit(history) with a healthy record."
            )
        h = np.asarray(history, dtype=float).ravel()
        h = h[np.isfinite(h)]
        if h.size < 10:
            raise DataError(
                f"history has {h.size} finite values; self-tuning needs at least 10."
            )
        centre = float(np.median(h))
        spread = 1.4826 * float(np.median(np.abs(h - centre)))
        if spread == 0:
            spread = float(np.std(h)) or 1e-12
        self.centre_, self.spread_ = centre, spread
        self.lower_ = centre - float(self.k) * spread
        self.upper_ = centre + float(self.k) * spread
        self.hysteresis_ = float(self.hysteresis) * (spread if self.relative else 1.0)
        return self

    def evaluate(self, x: ArrayLike, time: ArrayLike | None = None) -> MaskResult:
        """Symptoms and alarms of the record ``x`` (1-D)."""
        if not hasattr(self, "lower_"):
            if self.lower is None and self.upper is None:
                raise NotFittedError(
                    "self-tuned DiagnosticMask is not fitted; call fit(history) first."
                )
            self.fit()
        x = np.asarray(x, dtype=float)
        if x.ndim != 1:
            raise DataError(f"x must be 1-D (one tracked quantity); got shape {x.shape}.")
        t = np.arange(x.size) if time is None else np.asarray(time)
        if t.shape != x.shape:
            raise DataError(f"time has shape {t.shape}, x {x.shape}; they must match.")
        lo, hi, h = self.lower_, self.upper_, self.hysteresis_
        symptom = np.where(x > hi, 1, np.where(x < lo, -1, 0)).astype(int)
        outside = symptom != 0
        # clearing needs the value back inside the narrowed band (NaN counts as outside)
        inside_clear = (x >= lo + h) & (x <= hi - h)
        need = int(self.delay) + 1
        # run lengths of consecutive True up to each sample
        run_out = _run_lengths(outside)
        run_in = _run_lengths(inside_clear)
        alarm = np.zeros(x.size, dtype=bool)
        state = False
        for i in range(x.size):
            if not state and run_out[i] >= need:
                state = True
            elif state and run_in[i] >= need:
                state = False
            alarm[i] = state
        onsets = np.flatnonzero(alarm & ~np.r_[False, alarm[:-1]])
        return MaskResult(t, x, lo, hi, symptom, alarm, onsets)


def _run_lengths(flag: np.ndarray) -> np.ndarray:
    """Length of the run of True ending at each sample (0 where False)."""
    flag = np.asarray(flag, dtype=bool)
    idx = np.arange(flag.size)
    last_false = np.maximum.accumulate(np.where(~flag, idx, -1))
    return np.where(flag, idx - last_false, 0)


class DiagnosticMatrix:
    """Binary diagnostic matrix: which symptoms each fault produces.

    Parameters
    ----------
    table : pandas.DataFrame or mapping of str to sequence of 0/1
        Rows are faults, columns symptoms (a mapping ``fault -> symptom vector``
        needs ``symptoms`` for the column names).
    symptoms : sequence of str, optional
        Symptom names for a mapping.

    Raises
    ------
    pdmkit.errors.ModelError
        Two faults share a symptom vector (the message names both), or an entry is
        not 0/1.

    Examples
    --------
    >>> dm = DiagnosticMatrix(
    ...     {"unbalance": [1, 0, 0], "misalignment": [1, 1, 0], "bearing": [0, 0, 1]},
    ...     symptoms=["f1 up", "zeta1 up", "f2 down"],
    ... )
    >>> dm.diagnose([[1, 1, 0], [0, 0, 0], [0, 1, 1]]).tolist()
    ['misalignment', 'normal', 'unknown']
    """

    def __init__(
        self,
        table: pd.DataFrame | Mapping[str, Sequence[int]],
        symptoms: Sequence[str] | None = None,
    ) -> None:
        if isinstance(table, pd.DataFrame):
            frame = table.copy()
        elif isinstance(table, Mapping):
            rows = {str(k): list(v) for k, v in table.items()}
            lengths = {len(v) for v in rows.values()}
            if len(lengths) > 1:
                raise ModelError(
                    f"every fault needs a symptom vector of the same length; got "
                    f"lengths { {k: len(v) for k, v in rows.items()} }."
                )
            n = lengths.pop() if lengths else 0
            cols = (
                list(symptoms) if symptoms is not None else [f"S{i + 1}" for i in range(n)]
            )
            if len(cols) != n:
                raise ModelError(f"symptoms has {len(cols)} names for {n} columns.")
            frame = pd.DataFrame.from_dict(rows, orient="index", columns=cols)
        else:
            raise ModelError(
                f"table must be a DataFrame (faults x symptoms) or a mapping; got "
                f"{type(table).__name__}."
            )
        values = frame.to_numpy()
        if not np.isin(values, (0, 1)).all():
            raise ModelError("the diagnostic matrix must hold only 0 and 1 entries.")
        self.table = frame.astype(int)
        self.check()

    @property
    def faults(self) -> list[str]:
        """Fault names (rows)."""
        return [str(i) for i in self.table.index]

    @property
    def symptoms(self) -> list[str]:
        """Symptom names (columns)."""
        return [str(c) for c in self.table.columns]

    def check(self) -> None:
        """Raise :class:`~pdmkit.errors.ModelError` if two faults share a symptom vector.

        A fault with no symptom at all cannot be told from normal operation either.
        """
        seen: dict[tuple, str] = {}
        for fault, row in zip(self.faults, self.table.to_numpy(), strict=True):
            key = tuple(int(v) for v in row)
            if key in seen:
                raise ModelError(
                    f"faults {seen[key]!r} and {fault!r} share the symptom vector "
                    f"{list(key)}: they cannot be isolated; add a symptom that tells "
                    "them apart or merge them."
                )
            if not any(key):
                raise ModelError(
                    f"fault {fault!r} has no symptom (all zeros): it cannot be told from "
                    "normal operation."
                )
            seen[key] = fault

    def diagnose(self, symptoms: ArrayLike | pd.DataFrame) -> np.ndarray:
        """Fault name of each symptom vector.

        The exact match, ``"normal"`` for no symptom, ``"unknown"`` for a pattern no fault
        explains.

        Parameters
        ----------
        symptoms : array_like (n_symptoms,) or (n_obs, n_symptoms), or DataFrame
            Nonzero entries count as present (a mask's +1/-1 symptoms work too).
        """
        if isinstance(symptoms, pd.DataFrame):
            missing = [c for c in self.symptoms if c not in symptoms.columns]
            if missing:
                raise DataError(f"symptoms table lacks the column(s) {missing}.")
            s = symptoms[self.symptoms].to_numpy()
        else:
            s = np.atleast_2d(np.asarray(symptoms))
        if s.shape[1] != len(self.symptoms):
            raise DataError(
                f"symptom vectors have {s.shape[1]} entries; the matrix has "
                f"{len(self.symptoms)} symptoms {self.symptoms}."
            )
        b = (s != 0).astype(int)
        m = self.table.to_numpy()
        match = np.all(b[:, None, :] == m[None, :, :], axis=2)
        out = np.full(b.shape[0], "unknown", dtype=object)
        hit = match.any(axis=1)
        out[hit] = np.asarray(self.faults, dtype=object)[match.argmax(axis=1)[hit]]
        out[~b.any(axis=1)] = "normal"
        return out

    def to_pandas(self) -> pd.DataFrame:
        """The matrix (faults x symptoms)."""
        return self.table.copy()

    def plot(self, ax: Axes | None = None) -> Axes:
        """The matrix as a black/white grid; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(
                figsize=(1 + 0.6 * len(self.symptoms), 1 + 0.4 * len(self.faults))
            )
        ax.imshow(self.table.to_numpy(), cmap="Greys", vmin=0, vmax=1, aspect="auto")
        ax.set_xticks(range(len(self.symptoms)), self.symptoms, rotation=45, ha="right")
        ax.set_yticks(range(len(self.faults)), self.faults)
        ax.set_title("diagnostic matrix")
        return ax
