"""A measured recording as mismatch discovery fits it: uniform time, inputs, outputs.

:func:`make_recording` checks a table against a model and returns a :class:`Recording`;
:func:`part` cuts one; :func:`data_states` guesses states from the measured outputs.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit._checks import uniform_step
from pdmkit.errors import DataError

if TYPE_CHECKING:
    from pdmkit.models.ode import OdeModel

__all__ = [
    "Recording",
    "choose_input_hold",
    "data_states",
    "join_recordings",
    "make_recording",
    "measured_states",
    "part",
    "segments",
    "state_reading",
]


# ---------------------------------------------------------------------------- data
@dataclasses.dataclass
class Recording:
    """A measured recording: uniform time, the model's inputs and outputs.

    Attributes
    ----------
    time : ndarray, shape (N,)
    ts : float
        Sample interval (s).
    inputs : dict of str to ndarray (N,)
    outputs : dict of str to ndarray (N,)
    name : str
        Where it came from (used in messages).

    Examples
    --------
    >>> import numpy as np
    >>> import pandas as pd
    >>> from pdmkit.models.mismatch import make_recording
    >>> from pdmkit.models.ode import showcase_model
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(20) * 0.1
    >>> rec = make_recording(msd, pd.DataFrame({"time": t, "F": 1 + 0 * t, "x": 0 * t}))
    >>> rec.ts, list(rec.outputs)
    (0.1, ['x'])
    """

    time: np.ndarray
    ts: float
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    name: str = "data"
    #: the inputs between samples: "zoh" (held) or "foh" (straight lines)
    hold: str = "zoh"
    #: the time from which a drift counts (None: the first sample; a part of a longer
    #: record keeps the record's start)
    t_origin: float | None = None
    #: first sample of each recording joined into this one (:func:`join_recordings`);
    #: each starts from its own state
    starts: tuple[int, ...] = (0,)

    @property
    def n(self) -> int:
        return self.time.size

    def y(self, model) -> np.ndarray:
        """Outputs as an ``(N, n_outputs)`` array in the model's output order."""
        return np.stack([self.outputs[o] for o in model.outputs], 1)


def make_recording(model: OdeModel, data: Any, name: str = "data") -> Recording:
    """Check a table against a model and return a :class:`Recording`.

    Parameters
    ----------
    model : OdeModel
    data : pandas.DataFrame or mapping of column name to 1-D array
        A ``time`` column (s, uniform, increasing), one column per model input and
        one per model output, all finite.
    name : str
        The data's name or file, used in error messages.

    Returns
    -------
    Recording

    Raises
    ------
    pdmkit.errors.DataError
        A column is missing or not numeric, a value is NaN or infinite (the message
        names the column and the row), or the time is not uniform and increasing.

    Examples
    --------
    >>> from pdmkit.models.mismatch import make_recording
    >>> from pdmkit.models.ode import showcase_model
    >>> import numpy as np
    >>> t = np.arange(12) * 0.1
    >>> t[5:] += 0.1
    >>> make_recording(showcase_model("mass_spring_damper"),
    ...                {"time": t, "F": 0 * t, "x": 0 * t}, name="run.csv")
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: run.csv: time must be uniform; row 5 (time 0.6) is 0.2 s ...
    """
    columns = list(data.keys()) if not hasattr(data, "columns") else list(data.columns)
    need = ["time", *model.input_names, *model.outputs]
    missing = [c for c in need if c not in columns]
    if missing:
        raise DataError(
            f"{name}: missing column(s) {missing}; the model needs a 'time' column, its "
            f"inputs {model.input_names} and its outputs {model.outputs}. Found columns: "
            f"{columns}."
        )
    arrays = {}
    for c in need:
        raw = np.asarray(data[c])
        try:
            v = raw.astype(np.float64)
        except (TypeError, ValueError):
            raise DataError(
                f"{name}: column {c!r} must be numeric; found values such as "
                f"{raw[:3].tolist()}."
            ) from None
        if v.ndim != 1:
            raise DataError(f"{name}: column {c!r} must be 1-D; got shape {v.shape}.")
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise DataError(
                f"{name}: column {c!r} has {bad.size} missing or non-finite value(s), "
                f"first at row {int(bad[0])} ({v[bad[0]]}); fill or drop those rows."
            )
        arrays[c] = v
    t = arrays["time"]
    if t.size < 10:
        raise DataError(f"{name}: needs at least 10 samples; got {t.size}.")
    ts = uniform_step(t, name)
    t = t[0] + ts * np.arange(t.size)
    return Recording(
        time=t,
        ts=ts,
        inputs={c: arrays[c] for c in model.input_names},
        outputs={c: arrays[c] for c in model.outputs},
        name=name,
    )


def measured_states(model) -> dict[str, tuple[str, float, float]]:
    """States read by an output alone: ``{state: (output, gain, offset)}``.

    ``output = gain * state + offset`` (:meth:`OdeModel.output_states`); a state read
    by several outputs takes the first. Outputs computed from several states (a flow
    from two pressures) measure none.

    Examples
    --------
    >>> from pdmkit.models.ode import showcase_model
    >>> measured_states(showcase_model("mass_spring_damper"))
    {'x': ('x', 1.0, 0.0)}
    """
    out: dict[str, tuple[str, float, float]] = {}
    for o, (s, gain, offset) in model.output_states().items():
        out.setdefault(s, (o, gain, offset))
    return out


def state_reading(model, rec: Recording, state: str) -> np.ndarray | None:
    """The recording of ``state`` in the state's units (None when no output reads it)."""
    m = measured_states(model).get(state)
    if m is None:
        return None
    o, gain, offset = m
    return (np.asarray(rec.outputs[o], dtype=float) - offset) / gain


def data_states(model, rec: Recording, samples: np.ndarray, fallback) -> np.ndarray:
    """States at ``samples`` guessed from the data, ``(len(samples), nx)``.

    A measured state takes its output's reading; a velocity the slope of its measured
    position (over four samples); any other state ``fallback`` (``(nx,)`` or
    ``(len(samples), nx)``: e.g. a simulation's states there).
    """
    k = np.asarray(samples, dtype=int)
    X = np.array(
        np.broadcast_to(np.asarray(fallback, dtype=float), (k.size, len(model.states)))
    )
    readings = {s: state_reading(model, rec, s) for s in model.states}
    position = [
        q
        for q, kq in model.states.items()
        if kq in ("position", "angle") and readings[q] is not None
    ]
    for j, (s, kind) in enumerate(model.states.items()):
        if readings[s] is not None:
            X[:, j] = readings[s][k]
        elif kind in ("velocity", "angular_velocity") and len(position) == 1:
            y = readings[position[0]]
            lo, hi = np.maximum(k - 2, 0), np.minimum(k + 2, rec.n - 1)
            X[:, j] = (y[hi] - y[lo]) / ((hi - lo) * rec.ts)
    lo = np.array([0.0 if kd == "level" else -np.inf for kd in model.states.values()])
    return np.maximum(X, lo[None, :])


def part(rec: Recording, start: int = 0, stop: int | None = None) -> Recording:
    """Samples ``start:stop`` of a recording (a drift still counts from its start)."""
    cut = slice(start, stop)
    return dataclasses.replace(
        rec,
        t_origin=float(rec.time[0]) if rec.t_origin is None else rec.t_origin,
        time=rec.time[cut],
        inputs={k: v[cut] for k, v in rec.inputs.items()},
        outputs={k: v[cut] for k, v in rec.outputs.items()},
        starts=(0,),
    )


def join_recordings(recs: Sequence[Recording], name: str | None = None) -> Recording:
    """Recordings one after another, each still starting from its own state.

    The time continues from one to the next (one sample step between them); the
    starts are kept (:func:`segments` cuts them apart again). All must share the
    sample step and the input hold.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(4) * 0.5
    >>> a = Recording(t, 0.5, {"u": t}, {"y": t})
    >>> b = Recording(10 + t, 0.5, {"u": -t}, {"y": t})
    >>> both = join_recordings([a, b])
    >>> both.time.tolist(), both.starts
    ([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5], (0, 4))
    >>> [float(seg.time[0]) for seg in segments(both)]
    [0.0, 2.0]
    """
    recs = list(recs)
    if len(recs) == 1:
        return recs[0]
    ts = recs[0].ts
    for r in recs[1:]:
        if abs(r.ts - ts) > 1e-3 * ts or r.hold != recs[0].hold:
            raise DataError(
                f"{r.name}: sampled every {r.ts:g} s with hold {r.hold!r}; the first "
                f"recording ({recs[0].name}) every {ts:g} s with {recs[0].hold!r}."
            )
    starts = tuple(int(k) for k in np.cumsum([0] + [r.n for r in recs[:-1]]))
    n = sum(r.n for r in recs)
    return Recording(
        time=recs[0].time[0] + ts * np.arange(n),
        ts=ts,
        inputs={k: np.concatenate([r.inputs[k] for r in recs]) for k in recs[0].inputs},
        outputs={k: np.concatenate([r.outputs[k] for r in recs]) for k in recs[0].outputs},
        name=name or ", ".join(r.name for r in recs),
        hold=recs[0].hold,
        starts=starts,
    )


def segments(rec: Recording) -> list[Recording]:
    """The recordings :func:`join_recordings` put together, each on its own.

    A recording that was not joined is its one segment, unchanged (a part of a longer
    record keeps that record's start for a drift).
    """
    if len(rec.starts) == 1:
        return [rec]
    bounds = [*rec.starts, rec.n]
    out = []
    for a, b in itertools.pairwise(bounds):
        seg = part(rec, a, b)
        out.append(dataclasses.replace(seg, t_origin=float(rec.time[a])))
    return out


def choose_input_hold(rec: Recording) -> str:
    """``"zoh"`` when the inputs are held, else ``"foh"`` (a sampled continuous signal).

    Held inputs: most samples repeat the one before (steps, a digital controller's output).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(100) * 0.01
    >>> steps = np.repeat([0.0, 1.0, -1.0, 0.5], 25)
    >>> choose_input_hold(Recording(t, 0.01, {"u": steps}, {}))
    'zoh'
    >>> choose_input_hold(Recording(t, 0.01, {"u": np.sin(7 * t)}, {}))
    'foh'
    """
    if not rec.inputs:
        return "zoh"
    repeats = [
        float(np.mean(np.diff(np.asarray(u, dtype=float)) == 0))
        for u in rec.inputs.values()
    ]
    return "zoh" if max(repeats) > 0.3 else "foh"
