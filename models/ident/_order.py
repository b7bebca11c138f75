"""Which model and which orders: :func:`identify` and order selection by AIC/BIC/MDL."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from pdmkit._checks import check_fs as _check_fs
from pdmkit._progress import progress
from pdmkit.errors import DataError, ModelError
from pdmkit.models.ident._arx import ar, arx
from pdmkit.models.ident._model import CRITERIA, IdentifiedModel
from pdmkit.models.ident._pem import armax, bj, oe
from pdmkit.models.ident._subspace import n4sid

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["STRUCTURES", "OrderSelection", "identify", "select_order"]

#: Structures :func:`identify` dispatches to (name -> function of ``(u, y, fs, order)``).
STRUCTURES = ("ar", "arx", "armax", "oe", "bj", "n4sid")
_PEM = {"armax": armax, "oe": oe, "bj": bj}


# --------------------------------------------------------------------------- selection
@dataclass(eq=False)
class OrderSelection:
    """Candidate orders compared by an information criterion.

    Attributes
    ----------
    structure, criterion : str
    table : pandas.DataFrame
        One row per candidate: the order keys, ``n_params``, ``noise_variance``,
        ``aic``, ``bic``, ``mdl``, ``fit_percent``.
    best_order : dict
        The order with the lowest criterion.
    best_model : IdentifiedModel

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(3)
    >>> u, e = rng.normal(size=(2, 4000))
    >>> a = [1, -1.5, 0.7]
    >>> y = signal.lfilter([0, 1.0, 0.5], a, u) + signal.lfilter([0.1], a, e)
    >>> sel = select_order(u, y, "arx", orders=[1, 2, 3, 4], criterion="bic")
    >>> sel.best_order
    {'na': 2, 'nb': 2, 'nk': 1}
    """

    structure: str
    criterion: str
    table: pd.DataFrame
    best_order: dict
    best_model: IdentifiedModel = field(repr=False)

    def to_pandas(self) -> pd.DataFrame:
        """The comparison table."""
        return self.table.copy()

    def plot(self, ax: Axes | None = None) -> Axes:
        """Criterion against the number of parameters; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 3.5))
        t = self.table.sort_values("n_params")
        ax.plot(t["n_params"], t[self.criterion], "o-")
        ax.axvline(self.best_model.n_params, color="C3", ls="--", lw=1)
        ax.set_xlabel("parameters")
        ax.set_ylabel(self.criterion.upper())
        ax.set_title(f"{self.structure.upper()} order selection")
        return ax


def _expand_order(structure: str, order) -> dict:
    """A full order dict from an int (all polynomial orders equal) or a dict."""
    defaults = {
        "ar": {"na": None},
        "arx": {"na": None, "nb": None, "nk": 1},
        "armax": {"na": None, "nb": None, "nc": None, "nk": 1},
        "oe": {"nb": None, "nf": None, "nk": 1},
        "bj": {"nb": None, "nc": None, "nd": None, "nf": None, "nk": 1},
        "n4sid": {"nx": None},
    }
    if structure not in defaults:
        raise ModelError(f"structure must be one of {STRUCTURES}; got {structure!r}.")
    keys = defaults[structure]
    if isinstance(order, Mapping):
        unknown = sorted(set(order) - set(keys))
        if unknown:
            raise ModelError(
                f"order keys {unknown} do not belong to {structure!r}; it takes "
                f"{list(keys)}."
            )
        out = {**keys, **dict(order)}
        missing = [k for k, v in out.items() if v is None]
        if missing:
            raise ModelError(f"order for {structure!r} is missing {missing}.")
        return out
    if isinstance(order, bool) or not isinstance(order, int | np.integer):
        raise ModelError(
            f"order must be an int or a dict of {list(keys)} for {structure!r}; "
            f"got {order!r}."
        )
    return {k: (int(order) if v is None else v) for k, v in keys.items()}


def _fit_structure(structure: str, u, y, fs: float, order: dict, **kw) -> IdentifiedModel:
    if structure == "ar":
        return ar(y, order["na"], fs=fs)
    if structure == "arx":
        return arx(u, y, order["na"], order["nb"], order["nk"], fs=fs)
    if structure in _PEM:
        return _PEM[structure](u, y, **order, fs=fs, **kw)
    return n4sid(u, y, order["nx"], fs=fs, **kw)


def select_order(
    u: ArrayLike | None,
    y: ArrayLike,
    structure: str = "arx",
    orders: Iterable = range(1, 11),
    criterion: str = "aic",
    *,
    fs: float = 1.0,
    **kwargs,
) -> OrderSelection:
    """Fit every candidate order and keep the one with the lowest criterion.

    Parameters
    ----------
    u : array_like or None
        Input (None for ``"ar"``).
    y : array_like
        Output.
    structure : str, default "arx"
        One of :data:`STRUCTURES`.
    orders : iterable of int or dict
        Candidates: an int sets every polynomial order (``na = nb = n``, delay 1;
        ``nx = n`` for ``"n4sid"``), a dict gives them one by one.
    criterion : {"aic", "bic", "mdl"}
        See :meth:`IdentifiedModel.criterion`. BIC and MDL are consistent (pick the
        true order with probability -> 1); AIC tends to over-fit on long records.
    fs : float, default 1.0
    **kwargs
        Passed to the estimator (e.g. ``horizon`` for ``"n4sid"``).

    Returns
    -------
    OrderSelection

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(2)
    >>> y = signal.lfilter([1.0], [1, -1.6, 0.9], rng.normal(size=5000))
    >>> select_order(None, y, "ar", orders=range(1, 7), criterion="bic").best_order
    {'na': 2}
    """
    if criterion not in CRITERIA:
        raise ModelError(f"criterion must be one of {CRITERIA}; got {criterion!r}.")
    fs = _check_fs(fs)
    cands = [_expand_order(structure, o) for o in orders]
    if not cands:
        raise ModelError("orders is empty; give at least one candidate order.")
    rows, models = [], []
    # a bar on a terminal: PEM and subspace fits of long records take seconds each
    for o in progress(cands, desc=f"{structure} orders"):
        m = _fit_structure(structure, u, y, fs, o, **kwargs)
        models.append(m)
        rows.append(
            {
                **o,
                "n_params": m.n_params,
                "noise_variance": m.noise_variance,
                "aic": m.aic,
                "bic": m.bic,
                "mdl": m.mdl,
                "fit_percent": m.fit_percent,
            }
        )
    table = pd.DataFrame(rows)
    best = int(np.nanargmin(table[criterion].to_numpy()))
    return OrderSelection(structure, criterion, table, cands[best], models[best])


def identify(
    u: ArrayLike | None,
    y: ArrayLike,
    fs: float,
    structure: str = "arx",
    order: int | dict | None = None,
    criterion: str = "aic",
    *,
    max_order: int = 10,
    extend: bool = True,
    order_limit: int | None = None,
    **kwargs,
) -> IdentifiedModel:
    """Identify a linear model of the given structure; choose the order if not given.

    Parameters
    ----------
    u : array_like or None
        Input, shape (N,) (or (N, n_inputs) for ``"n4sid"``); None for ``"ar"``.
    y : array_like
        Output, shape (N,) (or (N, n_outputs) for ``"n4sid"``).
    fs : float
        Sampling rate in Hz.
    structure : {"ar", "arx", "armax", "oe", "bj", "n4sid"}
    order : int, dict or None
        An int sets every polynomial order (delay 1), a dict names them
        (``{"na": 4, "nb": 3, "nk": 1}``); None selects it from ``1..max_order``
        with ``criterion`` (:func:`select_order`).
    criterion : {"aic", "bic", "mdl"}, default "aic"
    max_order : int, default 10
    extend : bool, default True
        When the best order is the largest one searched, search on (the range
        doubled each time) up to ``order_limit``: an order at the edge of the range
        says the range was too small, not that the order is right.
    order_limit : int, optional
        Largest order an extended search tries (default ``4 * max_order`` for AR and
        ARX, ``2 * max_order`` for the others, and at most one parameter per 20
        samples). N4SID candidates are compared by their simulation error (no
        Kalman gain; the chosen order is then refitted as asked).
    **kwargs
        Passed to the estimator.

    Returns
    -------
    IdentifiedModel
        With ``info["selection"]`` (an :class:`OrderSelection`) and
        ``info["order_search"]`` (``searched``: ``[1, largest]``, ``best``,
        ``extended``, ``at_edge``, ``note``: a sentence for the user) when the order
        was selected.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=4000)
    >>> y = signal.lfilter([0, 0.2], [1, -1.7, 0.8], u) + 0.01 * rng.normal(size=4000)
    >>> m = identify(u, y, fs=100.0, structure="oe", order={"nb": 1, "nf": 2})
    >>> np.round(m.F, 2)
    array([ 1. , -1.7,  0.8])
    """
    if structure not in STRUCTURES:
        raise ModelError(
            f"structure must be one of {STRUCTURES}; got {structure!r}. "
            "(Nonlinear structures live in other modules.)"
        )
    if structure == "ar" and u is not None:
        u = None
    if structure != "ar" and u is None:
        raise DataError(f"structure {structure!r} needs an input u; got None.")
    if order is None:
        return _search_order(
            u, y, fs, structure, criterion, int(max_order), extend, order_limit, kwargs
        )
    return _fit_structure(
        structure, u, y, _check_fs(fs), _expand_order(structure, order), **kwargs
    )


def _order_size(order: dict) -> int:
    return max((v for k, v in order.items() if k != "nk"), default=0)


def _search_order(u, y, fs, structure, criterion, max_order, extend, limit, kwargs):
    """:func:`identify`'s order selection, extended while the best is at the edge."""
    if max_order < 1:
        raise ModelError(f"max_order must be an integer >= 1; got {max_order}.")
    n = np.asarray(y).shape[0]
    per_order = {"ar": 1, "arx": 2, "armax": 3, "oe": 2, "bj": 4, "n4sid": 2}[structure]
    if limit is None:
        limit = (4 if structure in ("ar", "arx") else 2) * max_order
        limit = max(max_order, min(limit, n // (20 * per_order)))
    limit = max(int(limit), max_order)
    final_kw = kwargs
    if structure == "n4sid" and "noise_model" not in kwargs:
        # candidates compared by their simulation error (the Kalman gain of each
        # would cost most of the search); the chosen order is refitted with it
        kwargs = {**kwargs, "noise_model": False}
    sel = select_order(u, y, structure, range(1, max_order + 1), criterion, fs=fs, **kwargs)
    first_best = _order_size(sel.best_order)
    hi = max_order
    while extend and _order_size(sel.best_order) == hi and hi < limit:
        new_hi = min(2 * hi, limit)
        more = select_order(
            u, y, structure, range(hi + 1, new_hi + 1), criterion, fs=fs, **kwargs
        )
        table = pd.concat([sel.table, more.table], ignore_index=True)
        if more.table[criterion].min() < sel.table[criterion].min():
            sel = OrderSelection(
                structure, criterion, table, more.best_order, more.best_model
            )
        else:
            sel = OrderSelection(
                structure, criterion, table, sel.best_order, sel.best_model
            )
        hi = new_hi
    best = _order_size(sel.best_order)
    at_edge = best == hi
    extended = hi > max_order
    name = structure.upper()
    if extended:
        note = (
            f"the best {name} order by {criterion.upper()} in 1..{max_order} was "
            f"{first_best}, at the edge of the range; the search was extended to "
            f"1..{hi}"
            + (
                f" and found {best}."
                if not at_edge
                else f", and the best order, {best}, is still at its edge."
            )
        )
    else:
        note = f"the best {name} order by {criterion.upper()} in 1..{hi} is {best}."
    if at_edge:
        note += (
            f" An order at the edge of the search ({hi}, the largest tried) suggests "
            "the data need more (or a --band to focus the fit, or decimation)."
        )
    model = sel.best_model
    if kwargs is not final_kw:
        model = _fit_structure(structure, u, y, _check_fs(fs), sel.best_order, **final_kw)
    model.info["selection"] = sel
    model.info["order_search"] = {
        "searched": [1, hi],
        "best": best,
        "extended": extended,
        "at_edge": at_edge,
        "note": note,
    }
    return model
