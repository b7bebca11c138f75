"""Long signals drawn so they read: decimated, with each bin's min-max envelope.

A line through 100 000 samples on a 1000-pixel axis is a solid block: every pixel
column holds a hundred samples. :func:`plot_signal` draws such a signal as the mean of
each of ``max_points // 2`` bins, shaded between the bin's minimum and maximum, so the
trend stays visible and no peak is lost; short signals are drawn sample by sample.
Reports (``pdmkit.experiments``) and result plots (``pdmkit.models``) share it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["MAX_POINTS", "axis_label", "envelope_note", "plot_signal"]

#: Above this many samples a signal is drawn decimated (about two per pixel column of
#: a report figure, 9-10 in wide at 110 dpi).
MAX_POINTS = 2000


def _bins(n: int, max_points: int) -> np.ndarray:
    """Start index of each bin (``max_points // 2`` bins of near-equal size)."""
    n_bins = max(1, min(n, max_points // 2))
    return np.unique(np.linspace(0, n, n_bins + 1).astype(int)[:-1])


def plot_signal(
    ax: Any,
    t: Any,
    y: Any,
    *,
    max_points: int = MAX_POINTS,
    color: Any = None,
    lw: float = 1.0,
    label: str | None = None,
    alpha: float = 0.3,
    **kwargs: Any,
) -> Any:
    """Draw ``y`` against ``t``; a long signal as bin means with a min-max envelope.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Where to draw.
    t, y : array-like
        Time (or any x) and values, the same length.
    max_points : int, default :data:`MAX_POINTS`
        Signals up to this many samples are drawn sample by sample; longer ones in
        ``max_points // 2`` bins: a line through each bin's mean (non-finite samples
        left out) and a band between its minimum and maximum.
    color, lw, label, **kwargs
        Passed to :meth:`~matplotlib.axes.Axes.plot` for the line (the band takes
        the line's colour).
    alpha : float, default 0.3
        Opacity of the envelope band.

    Returns
    -------
    matplotlib.lines.Line2D
        The line (for legends).

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> fig, ax = plt.subplots()
    >>> t = np.arange(100_000) / 1000.0
    >>> line = plot_signal(ax, t, np.sin(t) + np.random.default_rng(0).normal(size=t.size))
    >>> len(line.get_xdata())  # 1000 bins, not 100 000 samples
    1000
    >>> lo, hi = ax.collections[0].get_paths()[0].get_extents().intervaly
    >>> bool(lo < -4 and hi > 4)  # the envelope keeps the extremes
    True
    >>> plt.close(fig)
    """
    t = np.asarray(t, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if t.size != y.size:
        raise ValueError(
            f"plot_signal: t has {t.size} samples and y {y.size}; give one time per value"
        )
    if y.size <= max_points:
        return ax.plot(t, y, color=color, lw=lw, label=label, **kwargs)[0]
    starts = _bins(y.size, max_points)
    ends = np.append(starts[1:], y.size)
    finite = np.isfinite(y)
    clean = np.where(finite, y, np.nan)
    with np.errstate(all="ignore"):
        lo = np.fmin.reduceat(clean, starts)
        hi = np.fmax.reduceat(clean, starts)
        count = np.add.reduceat(finite.astype(float), starts)
        mean = np.add.reduceat(np.where(finite, y, 0.0), starts) / count
    mean[count == 0] = np.nan
    centre = 0.5 * (t[starts] + t[ends - 1])
    line = ax.plot(centre, mean, color=color, lw=lw, label=label, **kwargs)[0]
    ax.fill_between(centre, lo, hi, color=line.get_color(), alpha=alpha, lw=0)
    return line


def envelope_note(n_samples: int, max_points: int = MAX_POINTS) -> str:
    """A caption's sentence saying how :func:`plot_signal` drew a signal this long.

    Examples
    --------
    >>> envelope_note(500)
    ''
    >>> print(envelope_note(131072))
    131072 samples per line, drawn in 1000 bins: the line is each bin's mean, the band
    its minimum to maximum.
    """
    if n_samples <= max_points:
        return ""
    n_bins = len(_bins(int(n_samples), max_points))
    return (
        f"{int(n_samples)} samples per line, drawn in {n_bins} bins: the line is each "
        "bin's mean, the band its minimum to maximum."
    )


def axis_label(name: str, unit: str | None = None) -> str:
    """An axis label with its unit: ``"pa [Pa]"``; ``"acc (as recorded)"`` without one.

    A quantity whose unit pdmkit cannot know (a column of the user's file) says that
    its numbers are the recording's own, rather than showing a bare name.

    Examples
    --------
    >>> axis_label("pa", "Pa"), axis_label("acc")
    ('pa [Pa]', 'acc (as recorded)')
    """
    return f"{name} [{unit}]" if unit else f"{name} (as recorded)"
