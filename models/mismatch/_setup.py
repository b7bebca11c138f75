"""The recordings as a discovery fits them: hold, decimation, training part, pieces.

:func:`prepare` turns the user's recordings into a :class:`Setup`: the input hold
chosen, the record decimated where the model's dynamics allow, the output weights, the
integrator's step and, for a long record, the pieces it is fitted in. Several
validation recordings are joined one after another (:func:`join_recordings`), each
still starting from its own fitted state.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models.mismatch._fit import _initial_values, measured_scales
from pdmkit.models.mismatch._recording import (
    Recording,
    choose_input_hold,
    join_recordings,
    make_recording,
    part,
)
from pdmkit.models.mismatch._sampling import choose_pieces, choose_sampling, decimate

__all__ = ["Setup", "prepare", "validation_recordings"]


@dataclasses.dataclass
class Setup:
    """The recordings as the fits see them, and the settings taken from them."""

    rec: Recording
    rec_val: Recording | None  # several validation recordings joined (``starts``)
    hold: str
    factor: int  # decimation applied
    n_fit: int  # training samples of ``rec``
    y_all: np.ndarray  # measured outputs of ``rec`` (N, n_out)
    w: np.ndarray  # output weights (1 / std on the training part)
    values0: dict
    n_sub: int
    x_scale: dict
    pieces: tuple | None
    step_checked: bool = False  # n_sub chosen by simulation agreement, not the fastest mode
    n_separate: int = 0  # separate validation recordings (0: the last third of ``rec``)

    @property
    def validation(self) -> str:
        """What validates: ``"last third"`` or the separate recording(s)."""
        if self.n_separate == 0:
            return "last third"
        if self.n_separate == 1:
            return "separate recording"
        return f"{self.n_separate} separate recordings"


def _is_one_recording(validation: Any) -> bool:
    """One table (a DataFrame, a mapping or a Recording), not a list of them."""
    return isinstance(validation, Recording | Mapping) or hasattr(validation, "columns")


def validation_recordings(
    model, validation: Any, names: str | Sequence[str], data: Recording
) -> list[Recording]:
    """The validation recording(s) checked against the model and the training data.

    ``validation``: one table (DataFrame, mapping or :class:`Recording`) or a list of
    them; ``names``: one name, or one per table.
    """
    tables = [validation] if _is_one_recording(validation) else list(validation)
    if not tables:
        raise ModelError("discover_mismatch: validation is an empty list; give a table.")
    if isinstance(names, str):
        names = (
            [names] if len(tables) == 1 else [f"{names}[{i}]" for i in range(len(tables))]
        )
    if len(names) != len(tables):
        raise ModelError(
            f"discover_mismatch: {len(tables)} validation recordings but {len(names)} "
            "names."
        )
    recs = []
    for table, name in zip(tables, names, strict=True):
        r = table if isinstance(table, Recording) else make_recording(model, table, name)
        if abs(r.ts - data.ts) > 1e-3 * data.ts:  # as uniform_step's tolerance
            raise ModelError(
                f"discover_mismatch: {name} is sampled every {r.ts:g} s, "
                f"{data.name} every {data.ts:g} s; resample them to the same step."
            )
        recs.append(r)
    return recs


def prepare(model, data, validation, *, data_name, validation_name, input_hold):
    """The model as fitted (its integrator chosen) and the :class:`Setup`.

    The setup: recordings, input hold, decimation, training part, weights and pieces.
    """
    rec = data if isinstance(data, Recording) else make_recording(model, data, data_name)
    vals = []
    if validation is not None:
        vals = validation_recordings(model, validation, validation_name, rec)
    hold = choose_input_hold(rec) if input_hold == "auto" else input_hold
    if hold not in ("zoh", "foh"):
        raise ModelError(
            f"discover_mismatch: input_hold must be 'auto', 'zoh' or 'foh'; got "
            f"{input_hold!r}."
        )
    rec = dataclasses.replace(rec, hold=hold)
    vals = [dataclasses.replace(r, hold=hold) for r in vals]
    # a stiff model is integrated with ROS2; an oversampled record is decimated first
    # (the model and the inputs say how far)
    sampling = choose_sampling(model, rec, _initial_values(model, rec))
    model, factor = sampling.model, sampling.factor
    if factor > 1:
        rec = decimate(rec, factor)
        vals = [decimate(r, factor) for r in vals]
    rec_val = join_recordings(vals) if vals else None
    n_fit = rec.n if rec_val is not None else round(rec.n * 2 / 3)
    y_all = rec.y(model)
    w = 1.0 / np.maximum(np.std(y_all[:n_fit], axis=0), 1e-12)
    values0 = _initial_values(model, rec)
    n_sub = sampling.n_sub
    x_scale = measured_scales(model, rec)
    # a long record is fitted in pieces, each from its own fitted initial state
    pieces = choose_pieces(model, rec, n_fit, values0, n_sub)
    if pieces is not None and rec_val is None:  # validate on the tail, restarted
        rec_val = part(rec, n_fit)
    return model, Setup(
        rec,
        rec_val,
        hold,
        factor,
        n_fit,
        y_all,
        w,
        values0,
        n_sub,
        x_scale,
        pieces,
        sampling.checked,
        len(vals),
    )
