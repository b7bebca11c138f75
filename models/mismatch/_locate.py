"""Locate a mismatch: where the residual (measured - simulated) concentrates.

In time (:func:`residual_windows`: ranked windows with their share of residual energy),
in the state / input space (:func:`region_statistics`: residual energy over regions such
as near-zero velocity, direction reversals, high level, large input), in frequency
(:func:`residual_spectrum`: residual spectrum and coherence with each input), and
whether anything systematic is left (:func:`whiteness_test`: Ljung-Box and the
auto- and input cross-correlation against the +-2.58/sqrt(N) band, Ljung 1999), and
which recordings are clipped by their sensor (:func:`clipped_outputs`: a reading that
sits exactly at its extreme for a run of samples).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from pdmkit.errors import DataError
from pdmkit.models._residuals import whiteness_test

if TYPE_CHECKING:
    import pandas as pd
    from numpy.typing import ArrayLike

    from pdmkit.models.ode import OdeModel

__all__ = [
    "clipped_outputs",
    "region_statistics",
    "residual_spectrum",
    "residual_windows",
    "whiteness_test",
]

#: a run at the extreme this many times longer than the longest run of one repeated
#: value elsewhere (and at least CLIP_MIN_RUN samples) is a clip
CLIP_RUN_RATIO = 5
CLIP_MIN_RUN = 5


def _longest_runs(y: np.ndarray, edge: float) -> tuple[int, int]:
    """Longest run of samples exactly at ``edge``, longest run of one value elsewhere."""
    change = np.flatnonzero(np.diff(y) != 0)
    starts = np.r_[0, change + 1]
    lengths = np.diff(np.r_[starts, y.size])
    at = y[starts] == edge
    return int(lengths[at].max(initial=0)), int(lengths[~at].max(initial=1))


def clipped_outputs(outputs: Mapping[str, np.ndarray]) -> list[str]:
    """Outputs whose recording sits *exactly* at its maximum or minimum for a while.

    A measured quantity that reaches a physical limit (a tank's rim) still shows the
    sensor's noise there; a reading that repeats one value exactly, many times longer
    than any value repeats elsewhere in the record, is clipped by the sensor or the
    acquisition (its range, an amplifier's rail). The run must be at least
    ``CLIP_MIN_RUN`` samples and ``CLIP_RUN_RATIO`` times the longest run of one
    repeated value elsewhere (a coarse quantiser repeats values everywhere).

    Parameters
    ----------
    outputs : mapping of str to array
        The recorded outputs.

    Returns
    -------
    list of str
        The names of the clipped outputs.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._locate import clipped_outputs
    >>> noise = 0.01 * np.random.default_rng(0).normal(size=400)
    >>> y = np.sin(np.linspace(0, 20, 400)) + noise
    >>> clipped_outputs({"free": y, "clipped": np.minimum(y, 0.8)})
    ['clipped']
    """
    out = []
    for name, values in outputs.items():
        y = np.asarray(values, dtype=float)
        y = y[np.isfinite(y)]
        if y.size < 2 * CLIP_MIN_RUN or np.ptp(y) == 0:
            continue
        for edge in (y.max(), y.min()):
            run, elsewhere = _longest_runs(y, edge)
            if run >= max(CLIP_MIN_RUN, CLIP_RUN_RATIO * elsewhere):
                out.append(name)
                break
    return out


def _energy(residual) -> np.ndarray:
    r = np.asarray(residual, dtype=float)
    if r.ndim == 1:
        r = r[:, None]
    if r.ndim != 2:
        raise DataError(
            f"residual must be (n_samples,) or (n_samples, n_outputs); got {r.shape}."
        )
    return np.sum(r**2, axis=1)


def residual_windows(
    time: ArrayLike, residual: ArrayLike, n_windows: int = 20, top: int = 5
) -> list[dict]:
    """Time windows ranked by their share of the residual energy.

    The record is cut into ``n_windows`` equal windows; the ``top`` windows with the
    largest share of ``sum(residual**2)`` are returned best first, adjacent ones merged.

    Parameters
    ----------
    time : array_like, shape (N,)
    residual : array_like, shape (N,) or (N, n_outputs)
        Measured minus simulated (weighted when there are several outputs).
    n_windows : int
        Number of equal windows.
    top : int
        How many to keep (before merging).

    Returns
    -------
    list of dict
        ``{"start": s, "end": s, "share": fraction}``, largest share first.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._locate import residual_windows
    >>> t = np.arange(1000) * 0.1
    >>> r = np.random.default_rng(0).normal(0, 0.01, 1000)
    >>> r[300:350] += 1.0
    >>> w = residual_windows(t, r, top=1)
    >>> w[0]["start"], w[0]["end"], round(w[0]["share"], 2)
    (30.0, 35.0, 1.0)
    """
    t = np.asarray(time, dtype=float)
    e = _energy(residual)
    if e.size != t.size:
        raise DataError(f"time has {t.size} samples, residual {e.size}.")
    total = float(np.sum(e))
    n_windows = int(max(1, min(n_windows, t.size)))
    edges = np.linspace(0, t.size, n_windows + 1).round().astype(int)
    shares = np.array(
        [np.sum(e[a:b]) / total if total > 0 else 0.0 for a, b in itertools.pairwise(edges)]
    )
    order = np.argsort(-shares)[:top]
    chosen = sorted(order.tolist())
    merged: list[list[int]] = []
    for i in chosen:
        if merged and merged[-1][-1] == i - 1:
            merged[-1].append(i)
        else:
            merged.append([i])
    ts = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    out = []
    for grp in merged:
        a, b = edges[grp[0]], edges[grp[-1] + 1]
        out.append(
            {
                "start": float(t[a]),
                "end": float(t[b - 1] + ts),
                "share": float(np.sum(shares[grp])),
            }
        )
    out.sort(key=lambda d: -d["share"])
    return out


def _regions(model, x: Mapping[str, np.ndarray], u: Mapping[str, np.ndarray]):
    """Boolean masks of physically meaningful regions of the trajectory."""
    regions = []
    n = len(next(iter(x.values())))
    for s, kind in model.states.items():
        v = np.asarray(x[s], dtype=float)
        sd = float(np.std(v)) or 1.0
        if kind in ("velocity", "angular_velocity"):
            regions.append((f"{s} near 0", f"|{s}| < 0.1 std", np.abs(v) < 0.1 * sd))
            sign = np.sign(v)
            rev = np.flatnonzero(sign[1:] * sign[:-1] < 0)
            m = np.zeros(n, bool)
            for i in rev:
                m[max(0, i - 2) : i + 3] = True
            regions.append((f"{s} reversals", f"±2 samples around sign changes of {s}", m))
            regions.append(
                (
                    f"{s} large",
                    f"|{s}| in its top 20 %",
                    np.abs(v) >= np.quantile(np.abs(v), 0.8),
                )
            )
        elif kind in ("position", "angle"):
            dev = np.abs(v - np.median(v))
            regions.append(
                (
                    f"{s} large",
                    f"|{s} - median| in its top 20 %",
                    dev >= np.quantile(dev, 0.8),
                )
            )
        elif kind in ("level", "pressure", "temperature"):
            regions.append((f"{s} high", f"{s} in its top 15 %", v >= np.quantile(v, 0.85)))
            regions.append(
                (f"{s} low", f"{s} in its bottom 15 %", v <= np.quantile(v, 0.15))
            )
    for k, val in u.items():
        val = np.asarray(val, dtype=float)
        a = np.abs(val)
        regions.append((f"{k} large", f"|{k}| in its top 20 %", a >= np.quantile(a, 0.8)))
        regions.append(
            (f"{k} small", f"|{k}| < 10 % of its maximum", a < 0.1 * (a.max() or 1.0))
        )
        du = np.abs(np.diff(val, prepend=val[0]))
        big = du > max(np.quantile(du, 0.95), 1e-12)
        m = np.zeros(n, bool)
        for i in np.flatnonzero(big):
            m[i : i + 5] = True
        regions.append(
            (f"{k} changes", f"5 samples after the largest 5 % of steps in {k}", m)
        )
    regions.append(("start", "first 5 % of the record", np.arange(n) < max(1, n // 20)))
    return regions


def region_statistics(
    model: OdeModel,
    x: Mapping[str, np.ndarray],
    u: Mapping[str, np.ndarray],
    residual: np.ndarray,
) -> pd.DataFrame:
    """Residual energy over regions of the state / input space.

    For each region (near-zero and large velocity, direction reversals, large
    displacement, high and low level, large and small input, after input steps, the
    start of the record) the share of time spent there, the share of the residual
    energy found there, their ratio (*enrichment*: > 1 means the mismatch
    concentrates there) and the mean residual inside.

    Parameters
    ----------
    model : OdeModel
    x : dict of str to ndarray (N,)
        Simulated states.
    u : dict of str to ndarray (N,)
        Inputs.
    residual : ndarray, shape (N,) or (N, n_outputs)

    Returns
    -------
    pandas.DataFrame
        Columns ``region``, ``definition``, ``time_share``, ``energy_share``,
        ``enrichment``, ``mean_residual``, sorted by enrichment.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch._locate import region_statistics
    >>> t = np.linspace(0, 20, 2000)
    >>> x, v = np.sin(t), np.cos(t)
    >>> r = 0.01 * np.sign(v) * (np.abs(v) < 0.1)  # residual only near v = 0
    >>> tab = region_statistics(showcase_model("mass_spring_damper"), {"x": x, "v": v},
    ...                         {"F": np.sin(3 * t)}, r)
    >>> tab.iloc[0]["region"]
    'v near 0'
    """
    import pandas as pd

    e = _energy(residual)
    total = float(np.sum(e)) or 1.0
    r = np.asarray(residual, dtype=float)
    r1 = r if r.ndim == 1 else r.mean(axis=1)
    rows = []
    for name, definition, m in _regions(model, x, u):
        m = np.asarray(m, bool)
        if m.sum() == 0 or m.all():
            continue
        ts = float(m.mean())
        es = float(e[m].sum() / total)
        rows.append(
            {
                "region": name,
                "definition": definition,
                "time_share": ts,
                "energy_share": es,
                "enrichment": es / ts,
                "mean_residual": float(r1[m].mean()),
            }
        )
    df = pd.DataFrame(rows)
    if len(df):
        df = df.sort_values("enrichment", ascending=False, ignore_index=True)
    return df


def residual_spectrum(
    residual: ArrayLike, inputs: Mapping[str, np.ndarray], fs: float
) -> pd.DataFrame:
    """Welch spectrum of the residual and its coherence with each input.

    Parameters
    ----------
    residual : array_like, shape (N,)
    inputs : dict of str to array_like (N,)
    fs : float
        Sampling rate (Hz).

    Returns
    -------
    pandas.DataFrame
        Index ``frequency [Hz]``; columns ``psd`` and ``coherence <input>``.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._locate import residual_spectrum
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=4096)
    >>> spec = residual_spectrum(np.convolve(u, [0.5, 0.5], "same"), {"u": u}, fs=100.0)
    >>> bool(spec["coherence u"].iloc[1:20].min() > 0.9)
    True
    """
    import pandas as pd
    from scipy import signal

    r = np.asarray(residual, dtype=float).ravel()
    nper = int(min(256, max(8, r.size // 4)))
    f, p = signal.welch(r, fs=fs, nperseg=nper)
    cols = {"psd": p}
    for name, u in inputs.items():
        u = np.asarray(u, dtype=float).ravel()
        if np.std(u) == 0:
            continue
        _, c = signal.coherence(r, u, fs=fs, nperseg=nper)
        cols[f"coherence {name}"] = c
    return pd.DataFrame(cols, index=pd.Index(f, name="frequency [Hz]"))
