"""Simulation results: time, states, outputs, inputs; signals ``(n_members, n_samples)``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._xp import is_torch

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["ResponseData"]

_GROUPS = ("inputs", "states", "signals", "outputs")


def _as_2d(name: str, group: str, value: Any, n_samples: int):
    if not is_torch(value):
        value = np.asarray(value)
    if value.ndim == 1:
        value = value[None, :]
    if value.ndim != 2 or value.shape[1] != n_samples:
        raise ModelError(
            f"ResponseData: {group}[{name!r}] must have shape (n_members, {n_samples}) "
            f"(one row per member, one column per time sample); got {tuple(value.shape)}."
        )
    return value


def _numpy(value) -> np.ndarray:
    if is_torch(value):
        return value.detach().cpu().numpy()
    return np.asarray(value)


class ResponseData:
    """Time response of a simulated model for a batch of members.

    Every signal is an array of shape ``(n_members, n_samples)`` sampled at
    :attr:`time`; numpy arrays, or torch tensors on the differentiable path. Signals
    come in four groups: ``inputs`` (what drives the model), ``states`` (the ODE states),
    ``signals`` (other noise-free model quantities) and ``outputs`` (sensor readings).

    Parameters
    ----------
    time : array_like, shape (n_samples,)
        Sample times in s.
    states, outputs, inputs, signals : dict of str to array_like, optional
        Signals of each group, shape ``(n_members, n_samples)`` (1-D means one member).
    units : dict of str to str, optional
        Unit of each signal, shown in plots and column names.
    name : str
        A short label for plots.

    Attributes
    ----------
    n_members, n_samples : int
    fs : float
        Sampling rate in Hz (from the time vector).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models import ResponseData
    >>> t = np.arange(4) / 10.0
    >>> r = ResponseData(t, states={"x": np.array([[0.0, 1.0, 2.0, 3.0]])},
    ...                  units={"x": "m"})
    >>> r.n_members, r.fs
    (1, 10.0)
    >>> r.to_pandas().columns.tolist()
    ['x [m]']
    """

    def __init__(
        self,
        time: ArrayLike,
        states: Mapping[str, Any] | None = None,
        outputs: Mapping[str, Any] | None = None,
        inputs: Mapping[str, Any] | None = None,
        signals: Mapping[str, Any] | None = None,
        units: Mapping[str, str] | None = None,
        name: str = "response",
    ) -> None:
        self.time = np.asarray(time, dtype=np.float64)
        if self.time.ndim != 1 or self.time.size < 1:
            raise ModelError(
                f"ResponseData: time must be a 1-D array of sample times; got shape "
                f"{self.time.shape}."
            )
        n = self.time.size
        self.states = {k: _as_2d(k, "states", v, n) for k, v in (states or {}).items()}
        self.outputs = {k: _as_2d(k, "outputs", v, n) for k, v in (outputs or {}).items()}
        self.inputs = {k: _as_2d(k, "inputs", v, n) for k, v in (inputs or {}).items()}
        self.signals = {k: _as_2d(k, "signals", v, n) for k, v in (signals or {}).items()}
        self.units = dict(units or {})
        self.name = name
        rows = {v.shape[0] for g in _GROUPS for v in getattr(self, g).values()}
        if len(rows) > 1:
            raise ModelError(
                f"ResponseData: all signals must have the same number of members; found "
                f"{sorted(rows)}."
            )
        self.n_members = rows.pop() if rows else 0

    # ------------------------------------------------------------------ access
    @property
    def n_samples(self) -> int:
        return self.time.size

    @property
    def fs(self) -> float:
        if self.time.size < 2:
            return float("nan")
        return float(1.0 / np.median(np.diff(self.time)))

    def names(self) -> list[str]:
        """All signal names, inputs first, then states, signals and outputs."""
        return [k for g in _GROUPS for k in getattr(self, g)]

    def __getitem__(self, name: str):
        for g in ("outputs", "states", "signals", "inputs"):
            d = getattr(self, g)
            if name in d:
                return d[name]
        raise KeyError(
            f"{self.name} has no signal {name!r}; available: {', '.join(self.names())}"
        )

    def __contains__(self, name: str) -> bool:
        return any(name in getattr(self, g) for g in _GROUPS)

    def __repr__(self) -> str:
        parts = ", ".join(f"{len(getattr(self, g))} {g}" for g in _GROUPS)
        return (
            f"<{type(self).__name__} {self.name!r}: {self.n_members} members x "
            f"{self.n_samples} samples at {self.fs:g} Hz; {parts}>"
        )

    def _check_member(self, member: int) -> int:
        if not -self.n_members <= member < self.n_members:
            raise ModelError(
                f"{self.name}: member {member} out of range; the response has "
                f"{self.n_members} members (0..{self.n_members - 1})."
            )
        return member % self.n_members

    # ------------------------------------------------------------------ export
    def to_pandas(self, member: int = 0, groups: Sequence[str] = _GROUPS) -> pd.DataFrame:
        """One member's signals as a DataFrame indexed by time (s).

        Columns are ``"<name> [<unit>]"`` (just ``<name>`` when the unit is unknown), in
        the order inputs, states, signals, outputs.

        Parameters
        ----------
        member : int
            Which member (row).
        groups : sequence of str
            Which groups to include, from ``("inputs", "states", "signals", "outputs")``.

        Returns
        -------
        pandas.DataFrame

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models import ResponseData
        >>> r = ResponseData(np.arange(3) / 2.0, outputs={"y": np.ones((2, 3))})
        >>> r.to_pandas(member=1).shape
        (3, 1)
        """
        import pandas as pd

        member = self._check_member(member)
        cols = {}
        for g in groups:
            if g not in _GROUPS:
                raise ModelError(f"to_pandas: unknown group {g!r}; choose from {_GROUPS}.")
            for k, v in getattr(self, g).items():
                unit = self.units.get(k)
                cols[f"{k} [{unit}]" if unit else k] = _numpy(v[member])
        idx = pd.Index(self.time, name="time [s]")
        return pd.DataFrame(cols, index=idx)

    def _default_signals(self) -> list[str]:
        return list(self.outputs or self.states)[:4]

    def plot(
        self,
        ax: Axes | Sequence[Axes] | None = None,
        signals: Sequence[str] | None = None,
        member: int | Sequence = 0,
    ) -> np.ndarray:
        """Plot signals against time (matplotlib imported here).

        Parameters
        ----------
        ax : matplotlib Axes or sequence of Axes, optional
            One axes: every signal is drawn on it. A sequence: one signal per axes.
            None: a new figure with one row per signal.
        signals : sequence of str, optional
            Signal names (any group); default: a few representative ones.
        member : int or sequence of int
            Member(s) to draw.

        Returns
        -------
        numpy.ndarray of Axes

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models import ResponseData
        >>> r = ResponseData(np.arange(5) / 5.0, states={"x": np.arange(5.0)})
        >>> r.plot(signals=["x"]).shape
        (1,)
        """
        import matplotlib.pyplot as plt

        signals = list(signals) if signals is not None else self._default_signals()
        for s in signals:
            self[s]
        members = [member] if isinstance(member, int | np.integer) else list(member)
        members = [self._check_member(int(m)) for m in members]
        if ax is None:
            _, axes = plt.subplots(
                len(signals), 1, sharex=True, squeeze=False, figsize=(8, 1.8 * len(signals))
            )
            axes = axes[:, 0]
        elif isinstance(ax, Sequence | np.ndarray):
            axes = np.asarray(ax, dtype=object).ravel()
            if axes.size != len(signals):
                raise ModelError(
                    f"plot: got {axes.size} axes for {len(signals)} signals; pass one axes "
                    "per signal, a single axes, or None."
                )
        else:
            axes = np.array([ax] * len(signals), dtype=object)
        for a, s in zip(axes, signals, strict=True):
            data = _numpy(self[s])
            unit = self.units.get(s)
            for m in members:
                label = s if len(members) == 1 else f"{s} (member {m})"
                a.plot(self.time, data[m], label=label, lw=0.8)
            a.set_ylabel(f"{s}\n[{unit}]" if unit and len(set(map(id, axes))) > 1 else s)
        axes[-1].set_xlabel("time [s]")
        if len(set(map(id, axes))) == 1 and len(signals) > 1:
            axes[0].legend(loc="best", fontsize="small")
        return axes
