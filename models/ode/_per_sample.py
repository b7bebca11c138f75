"""Per-sample evaluation of model functions written for scalars (``math``, ``if``, ``max``).

pdmkit simulates many members at once, so it calls a model's ``rhs`` (and ``outputs``)
with numpy arrays. A file written as an engineer writes equations on paper (the
source thesis's chapter 4: ``math.sqrt``, ``max``/``min``, ``if``/``elif`` on a
pressure ratio or a position) cannot take arrays: ``math.sqrt`` wants one number and
``if p_ratio > b`` has no single truth value for an array. Such a function is wrapped by
:func:`per_sample`: it is called once per element with plain floats and the results
are gathered back into arrays of the batch's shape. This is exact (the same arithmetic
as a numpy version of the same equations) but costs one Python call per member and
stage; a numpy version of the file (``np.sqrt``, ``np.where``, ``np.minimum``) is
typically 20-100 times faster on a batch.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._xp import is_torch

__all__ = ["per_sample"]


def _shape(v: Any) -> tuple[int, ...]:
    return tuple(getattr(v, "shape", ()))


def per_sample(fn: Callable, where: str, what: str = "rhs") -> Callable:
    """``fn(t, x, u, p)`` evaluated element by element over array arguments.

    Scalars pass straight through; arrays (any shape that broadcasts) are visited one
    element at a time with Python floats, and each returned value becomes an array of
    the broadcast shape.

    Parameters
    ----------
    fn : callable
        ``fn(t, x, u, p) -> dict`` written for scalars.
    where : str
        How messages name the model (``model file <path>``).
    what : str
        The function's name in messages (``rhs`` or ``outputs``).

    Returns
    -------
    callable
        The wrapped function; its ``per_sample`` attribute is True.

    Examples
    --------
    >>> import math
    >>> import numpy as np
    >>> def rhs(t, x, u, p):
    ...     return {"h": -math.sqrt(x["h"]) if x["h"] > 0 else 0.0}
    >>> f = per_sample(rhs, "model")
    >>> f(0.0, {"h": np.array([4.0, -1.0, 9.0])}, {}, {})["h"].tolist()
    [-2.0, 0.0, -3.0]
    >>> f(0.0, {"h": 4.0}, {}, {})
    {'h': -2.0}
    """

    @functools.wraps(fn)
    def each(t, x, u, p):
        groups = (x, u, p)
        shapes = [_shape(t)] + [_shape(v) for g in groups for v in g.values()]
        if not any(shapes):
            return fn(t, x, u, p)
        if is_torch(t) or any(is_torch(v) for g in groups for v in g.values()):
            raise ModelError(
                f"{where}: {what} is evaluated per sample (it uses math, if or max/min "
                "on values), which works on numpy only; write it with numpy functions "
                "(np.sqrt, np.where, np.minimum) to simulate with torch."
            )
        shape = np.broadcast_shapes(*shapes)
        flat = [
            {
                k: np.broadcast_to(np.asarray(v, dtype=float), shape).ravel().tolist()
                for k, v in g.items()
            }
            for g in groups
        ]
        tt = np.broadcast_to(np.asarray(t, dtype=float), shape).ravel().tolist()
        xs, us, ps = flat
        first = None
        cols: dict[str, list] = {}
        for i in range(len(tt)):
            out = fn(
                tt[i],
                {k: v[i] for k, v in xs.items()},
                {k: v[i] for k, v in us.items()},
                {k: v[i] for k, v in ps.items()},
            )
            if first is None:
                if not isinstance(out, Mapping):
                    return out  # the caller reports the wrong return type
                first = list(out)
                cols = {k: [] for k in first}
            for k in first:
                cols[k].append(out[k] if k in out else np.nan)
        return {k: np.asarray(v, dtype=float).reshape(shape) for k, v in cols.items()}

    each.per_sample = True  # type: ignore[attr-defined]
    return each
