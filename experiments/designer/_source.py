"""Where the designer's members come from.

A named dataset, member files, an on-disk ensemble or a feature table. A :class:`Source`
holds the condition variables of every member (one small table) and reads signals member
by member on request; an on-disk ensemble is never loaded whole (its signals are read
one member's row group at a time). It also says how the same members are loaded from a
script and from the ``pdmkit`` command line, so that the export reproduces what the page
did.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.ensembles import (
    Ensemble,
    iter_parquet,
    parquet_partitions,
    read_partition,
    read_table,
)
from pdmkit.errors import DataError
from pdmkit.experiments._datasets import get_profile
from pdmkit.experiments._sources import MEMBER_OPTIONS, TableSource, member_ensemble

__all__ = ["SOURCE_KINDS", "Source", "default_label", "member_reading", "open_source"]

#: the kinds of input ``pdmkit designer`` opens (its mutually exclusive options)
SOURCE_KINDS = ("dataset", "members", "ensemble", "features")

#: how the script loads a named dataset: the call its profile makes (a test checks
#: that the two give the same members)
DATASET_LOADERS = {"cwru": ("load_cwru", "frame_length=2048, fs=12000.0")}

#: most members whose signals are read at once for a plot
MAX_PLOT_MEMBERS = 40


@dataclass
class Source:
    """The members the designer works on.

    Attributes
    ----------
    kind : str
        One of :data:`SOURCE_KINDS`.
    value : str or list of str
        The dataset name, the member files, the ensemble folder or the feature table.
    conditions : pandas.DataFrame
        One row per member (index: member ids), the condition variables.
    signals : dict
        Signal name -> sampling rate (Hz); empty for a feature table.
    label : str or None
        The condition holding the class (the dataset's, else a guess).
    default_signals : list of str
        Signals whose indicators are computed by default.
    default_groups : list of str
        Indicator groups computed by default.
    default_options : dict
        Group options the dataset's profile sets (the command line applies them).
    ensemble : Ensemble or None
        The members in memory (datasets and member files).
    features : pandas.DataFrame or None
        The feature table of a ``features`` source.
    reading : dict
        How member files were read: the options of :data:`MEMBER_OPTIONS` given
        (``{"labels": "labels.csv", "resample": 12000.0, "frame": "2048"}``), as the
        export passes them on (``--labels ...``, ``read_members(..., labels=...)``).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> ens = Ensemble({"vib": np.zeros((2, 8))}, fs=8.0, conditions={"fault": ["a", "b"]})
    >>> src = Source.from_ensemble(ens)
    >>> src.label, src.signals, len(src.conditions)
    ('fault', {'vib': 8.0}, 2)
    >>> src.read("m00001", "vib").shape
    (8,)
    """

    kind: str
    value: Any
    conditions: pd.DataFrame
    signals: dict[str, float]
    label: str | None = None
    default_signals: list[str] = field(default_factory=list)
    default_groups: list[str] = field(default_factory=lambda: ["stats", "spectral"])
    default_options: dict[str, Any] = field(default_factory=dict)
    ensemble: Any = None
    features: pd.DataFrame | None = None
    reading: dict[str, Any] = field(default_factory=dict)
    _partition: Any = None

    @classmethod
    def from_ensemble(cls, ensemble, kind: str = "members", value: Any = None) -> Source:
        """A source of an ensemble already in memory."""
        conditions = ensemble.conditions
        return cls(
            kind=kind,
            value=value,
            conditions=conditions,
            signals=dict(ensemble.fs),
            label=default_label(conditions),
            default_signals=list(ensemble.signal_names),
            ensemble=ensemble,
        )

    # ---------------------------------------------------------------- reading
    def describe(self) -> str:
        """One line: what was opened and how many members it has."""
        what = {
            "dataset": f"dataset {self.value}",
            "members": f"{len(self.value or [])} member file(s)",
            "ensemble": f"on-disk ensemble {self.value}",
            "features": f"feature table {self.value}",
        }.get(self.kind, str(self.kind))
        return f"{what}: {len(self.conditions)} members"

    def read(self, member: str, signal: str) -> np.ndarray | None:
        """One member's signal (None when the member lacks it)."""
        if signal not in self.signals:
            raise DataError(
                f"signal {signal!r} is not in this ensemble; its signals are "
                f"{sorted(self.signals)}"
            )
        if member not in self.conditions.index:
            raise DataError(f"no member {member!r} in this ensemble")
        if self.ensemble is not None:
            return self.ensemble.select([member]).signal(signal)[0]

        pos = int(self.conditions.index.get_loc(member))
        part = dataclasses.replace(self._partition, index=0, start=pos, stop=pos + 1)
        return read_partition(part, signals=[signal], columns=[]).signal(signal)[0]

    def extraction_input(self, members: pd.Index, batch_size: int):
        """(batches of the chosen members, number of batches) for the extractor."""
        n = len(members)
        if n == 0:
            raise DataError("no member is selected; clear the filter of the member table")
        total = math.ceil(n / batch_size)
        if self.ensemble is not None:
            chosen = self.ensemble
            if n != len(self.conditions):
                chosen = self.ensemble.select(list(members))
            return chosen.batches(batch_size), total

        keep = set(members)
        whole = n == len(self.conditions)

        def batches():
            for batch in iter_parquet(self.value, batch_size=batch_size):
                if not whole:
                    mask = np.fromiter((m in keep for m in batch.member_ids), bool)
                    if not mask.any():
                        continue
                    batch = batch.select(mask)
                yield batch

        total = math.ceil(len(self.conditions) / batch_size)
        return batches(), total


def default_label(conditions: pd.DataFrame) -> str | None:
    """The condition most likely to hold the class.

    ``fault``, ``label``, ... when present, else the first text column with 2 to 50
    values.

    Examples
    --------
    >>> import pandas as pd
    >>> default_label(pd.DataFrame({"rpm": [1, 2], "state": ["ok", "worn"]}))
    'state'
    """
    for name in ("fault", "label", "seed_label", "class", "condition"):
        if name in conditions.columns:
            return name
    for name in conditions.columns:
        column = conditions[name]
        if not pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(
            column
        ):
            if 2 <= column.nunique() <= 50:
                return str(name)
    return None


def _dataset_source(name: str) -> Source:

    profile = get_profile(name)
    if name not in DATASET_LOADERS:
        raise DataError(f"dataset {name!r} has no loader the designer can export")
    source = Source.from_ensemble(profile.load(), kind="dataset", value=name)
    source.label = profile.label
    source.default_signals = list(profile.classify_signals or source.signals)
    source.default_groups = [g for g in profile.groups if g in ("stats", "spectral")]
    source.default_options = profile.options()
    return source


def _ensemble_source(path: str) -> Source:

    if "://" in str(path):
        raise DataError(
            f"--ensemble {path}: the designer reads local ensemble folders; copy it here"
        )
    folder = Path(path)
    head = Ensemble.from_parquet(folder, signals=[])  # conditions only: small
    parts = parquet_partitions(folder)
    if not parts:
        raise DataError(f"--ensemble {path} holds no members")
    conditions = head.conditions
    manifest = parts[0].manifest
    signals = {str(s): float(manifest["fs"][s]) for s in manifest["signals"]}
    return Source(
        kind="ensemble",
        value=str(folder),
        conditions=conditions,
        signals=signals,
        label=default_label(conditions),
        default_signals=list(signals),
        _partition=parts[0],
    )


def _members_source(files: list[str], reading: dict) -> Source:
    """The member files, read as ``pdmkit features --members`` reads them."""
    ensemble, _ = member_ensemble(TableSource(members=files, **reading))
    source = Source.from_ensemble(ensemble, kind="members", value=[str(f) for f in files])
    source.reading = dict(reading)
    return source


def member_reading(args: Any) -> dict[str, Any]:
    """The ``--members`` reading options a command line gave (:data:`MEMBER_OPTIONS`).

    Only those given; paths as text.

    Examples
    --------
    >>> import argparse, pathlib
    >>> member_reading(argparse.Namespace(fs=None, labels=pathlib.Path("l.csv"),
    ...                                   frame="2048", host="127.0.0.1"))
    {'labels': 'l.csv', 'frame': '2048'}
    """
    out = {}
    for name in MEMBER_OPTIONS:
        value = getattr(args, name, None)
        if value is not None:
            out[name] = str(value) if isinstance(value, os.PathLike) else value
    return out


def _features_source(path: str) -> Source:

    table = read_table(path)
    if table.index.name is None and "member" in table.columns:
        table = table.set_index("member")
    table.index = table.index.astype(str)
    if not table.index.is_unique:
        table.index = pd.Index([f"m{i:05d}" for i in range(len(table))], name="member")
    conditions = table[[c for c in table.columns if "/" not in str(c)]]
    return Source(
        kind="features",
        value=str(path),
        conditions=conditions,
        signals={},
        label=default_label(conditions),
        default_groups=[],
        features=table,
    )


def open_source(kind: str, value: Any, reading: dict | None = None) -> Source:
    r"""Open the members that ``pdmkit designer`` was started on.

    Parameters
    ----------
    kind : {"dataset", "members", "ensemble", "features"}
        Which option named them.
    value : str or list of str
        The dataset name, member files, ensemble folder or feature table.
    reading : dict, optional
        How member files are read (``kind="members"`` only): ``fs``, ``time``,
        ``label_from_name``, ``labels``, ``resample``, ``frame``, ``hop``, as
        :func:`pdmkit.ensembles.read_members` takes them (see :func:`member_reading`).

    Returns
    -------
    Source

    Raises
    ------
    pdmkit.errors.DataError
        An unknown kind or dataset, a folder that is no pdmkit ensemble, unreadable
        files (the message names them).

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> ens = Ensemble({"x": np.ones((3, 16))}, fs=16.0, conditions={"label": list("aab")})
    >>> path = ens.to_parquet(pathlib.Path(tempfile.mkdtemp()) / "ens")
    >>> src = open_source("ensemble", str(path))
    >>> src.label, src.conditions.index.tolist(), src.read("m00002", "x")[:2]
    ('label', ['m00000', 'm00001', 'm00002'], array([1., 1.]))

    Member files in frames, labelled from a table:

    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("a", "b"):
    ...     np.savez(d / f"{name}.npz", vib=np.ones(100))
    >>> _ = (d / "labels.csv").write_text("file,fault,fs\na.npz,ok,50\nb.npz,worn,50\n")
    >>> src = open_source("members", [d / "a.npz", d / "b.npz"],
    ...                   {"labels": d / "labels.csv", "frame": "1s"})
    >>> src.label, src.signals, src.conditions["source_member"].tolist()
    ('fault', {'vib': 50.0}, ['a', 'a', 'b', 'b'])
    """
    reading = {k: v for k, v in (reading or {}).items() if v is not None}
    unknown = sorted(set(reading) - set(MEMBER_OPTIONS))
    if unknown:
        raise DataError(f"unknown member reading option(s) {unknown}")
    if reading and kind != "members":
        flags = ", ".join("--" + k.replace("_", "-") for k in reading)
        raise DataError(
            f"{flags} applies to --members files; the --{kind} source is read as it is. "
            "Give the recordings with --members"
        )
    if kind == "dataset":
        return _dataset_source(str(value))
    if kind == "ensemble":
        return _ensemble_source(os.fspath(value))
    if kind == "members":
        files = [os.fspath(v) for v in ([value] if isinstance(value, str) else value)]
        return _members_source(files, reading)
    if kind == "features":
        return _features_source(os.fspath(value))
    raise DataError(f"source kind must be one of {list(SOURCE_KINDS)}; got {kind!r}")
