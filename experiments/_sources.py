"""Where the feature-table workflows get their members: :class:`TableSource`.

``features``, ``rank``, ``classify`` and ``sensors`` (and :func:`run_features`,
:func:`run_rank`, :func:`run_classify`, :func:`run_sensors`) read a named dataset, an
on-disk ensemble, member files or (all but ``features``) a feature table. A
:class:`TableSource` names one of them with its reading options, spelt as the
command's flags are; this module turns it into an ensemble or a feature table. It also
holds the flags that say how ``--members`` files are read (:func:`add_member_options`),
shared with ``pdmkit designer``.
"""

from __future__ import annotations

import argparse
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path

import pandas as pd

from pdmkit._checks import parse_timestamps
from pdmkit.errors import DataError, DataWarning, did_you_mean
from pdmkit.experiments._cli_common import input_paths, parse_options
from pdmkit.experiments._messages import say

__all__ = [
    "MEMBER_OPTIONS",
    "TableSource",
    "add_member_options",
    "extraction_input",
    "feature_table",
    "member_ensemble",
    "order_column",
    "parse_sensors",
    "require_label",
]

#: The :class:`TableSource` fields (and flags, ``_`` as ``-``) that say how ``--members``
#: files are read; they apply to member files only.
MEMBER_OPTIONS = ("fs", "time", "label_from_name", "labels", "resample", "frame", "hop")


@dataclass(frozen=True)
class TableSource:
    """One source of members or indicators, with its reading options.

    Give exactly one of ``dataset``, ``ensemble``, ``members`` or ``features``; the
    other fields are the options of ``pdmkit features / rank / classify / sensors``
    (``--fs``, ``--label``, ...), with the same meaning.

    Parameters
    ----------
    dataset : str, optional
        A named dataset (``pdmkit datasets``), e.g. ``"cwru"``.
    ensemble : str or path, optional
        A Parquet ensemble folder or its fsspec URL (streamed in batches).
    members : sequence of path, optional
        Member files, one recording each (folders and glob patterns too).
    features : path, optional
        A feature table (Parquet, CSV or text) whose indicators are extracted already.
    fs : float, optional
        Sampling rate of the member files in Hz.
    label : str, optional
        The condition column holding the class label.
    groups, signals : sequence of str, optional
        Indicator groups to extract; signals whose indicators are used.
    options : mapping, optional
        Indicator-group options (``{"ar_order": 12}``), see
        :data:`pdmkit.features.FEATURE_GROUPS`.
    time : str, optional
        The time column of the member tables or of the feature table.
    label_from_name : str, optional
        A regular expression taking each member file's label from its name.
    labels : path, optional
        A table of the member files' conditions.
    bearing : str, optional
        The bearing of the envelope indicators (a name such as ``"6205"``).
    shaft_hz : float or str, optional
        The shaft speed in Hz, or the condition column holding each member's.
    resample : float, optional
        Resample every member file to this rate in Hz (``--resample``).
    frame, hop : int or str, optional
        Cut every member file into frames of ``frame`` samples (or ``"0.1s"``,
        ``"100ms"``), ``hop`` apart (``--frame``, ``--hop``); see
        :func:`pdmkit.ensembles.read_members`.
    quiet : bool, default False
        No progress bars.

    Examples
    --------
    >>> from pdmkit.experiments import TableSource
    >>> source = TableSource(members=["runs/"], fs=1000.0, label_from_name=r"^([a-z]+)_")
    >>> source.input_paths()
    ['runs/']
    >>> TableSource(dataset="cwru", frame="2048")
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: --frame applies to --members files ...
    """

    dataset: str | None = None
    ensemble: str | os.PathLike | None = None
    members: Sequence[str | os.PathLike] | None = None
    features: str | os.PathLike | None = None
    fs: float | None = None
    label: str | None = None
    groups: Sequence[str] | None = None
    signals: Sequence[str] | None = None
    options: Mapping[str, object] = field(default_factory=dict)
    time: str | None = None
    label_from_name: str | None = None
    labels: str | os.PathLike | None = None
    bearing: str | None = None
    shaft_hz: float | str | None = None
    resample: float | None = None
    frame: int | str | None = None
    hop: int | str | None = None
    quiet: bool = False

    def __post_init__(self) -> None:
        given = [
            n for n in ("dataset", "ensemble", "members", "features") if getattr(self, n)
        ]
        if len(given) != 1:
            raise DataError(
                "give exactly one source of members: dataset, ensemble, members or "
                f"features; got {given or 'none'}"
            )
        reading = [n for n in ("resample", "frame", "hop") if getattr(self, n) is not None]
        if reading and not self.members:
            flags = ", ".join("--" + n for n in reading)
            raise DataError(
                f"{flags} applies to --members files (each read, resampled and cut into "
                f"frames as it comes); the --{given[0]} source is read as it is. Give "
                "the recordings with --members, or frame them in Python "
                "(Ensemble.resample, Ensemble.frames)"
            )
        # a bad --frame / --hop / --resample: read_members' error, before any reading

    @classmethod
    def from_namespace(cls, args: argparse.Namespace) -> TableSource:
        """The source a command's parsed flags name (``--option`` read as KEY=VALUE)."""
        values = {f.name: getattr(args, f.name, None) for f in fields(cls)}
        values["options"] = parse_options(getattr(args, "option", None) or [])
        values["quiet"] = bool(getattr(args, "quiet", False))
        return cls(**values)

    @property
    def progress(self) -> bool | None:
        """Progress bars: off when quiet, else on a terminal only (None)."""
        return False if self.quiet else None

    def input_paths(self) -> list:
        """The files and folders this source reads (never overwritten by an output)."""
        return input_paths(self)


def extraction_input(
    source: TableSource, on_error: str = "raise", json_path: str | os.PathLike | None = None
):
    """(ensemble or path/URL, groups, options, label, sensors, profile, read errors)."""
    from pdmkit.experiments._datasets import get_profile
    from pdmkit.features import GROUPS, check_group_options, check_groups, group_of_option

    groups = tuple(source.groups) if source.groups else ("stats", "spectral")
    extra = dict(source.options)
    try:  # a misspelt group or --option is an input error (exit 2), before loading
        if source.groups:
            check_groups(source.groups)
        check_group_options(GROUPS, extra, where="pdmkit --option")
    except TypeError as exc:
        raise DataError(str(exc)) from None
    extra = {**extra, **_bearing_options(source)}
    members = source.members
    for flag, value in (
        ("--label-from-name", source.label_from_name),
        ("--labels", source.labels),
        ("--time", source.time),
    ):
        if value is not None and not members:
            raise DataError(
                f"{flag} applies to --members files (or, --time, to a --features "
                "table); give the member files with --members"
            )
    if source.dataset is not None:
        profile = get_profile(source.dataset)
        say(f"loading dataset {profile.name!r}")
        ensemble = profile.load()
        groups = tuple(source.groups) if source.groups else profile.groups
        groups = _envelope_group(groups, {"bearing": None}, source)
        sensors = {k: list(v) for k, v in profile.sensors.items()}
        label = source.label or profile.label
        # the profile's defaults serve the groups chosen; the user's own must match
        defaults = {
            k: v for k, v in profile.options().items() if group_of_option(k) in groups
        }
        options = {**defaults, **extra}
        _check_label(ensemble, label, f"dataset {profile.name!r}")
        return ensemble, groups, options, label, sensors, profile, None
    groups = _envelope_group(groups, extra, source)
    if members:
        written = json_path
        if source.labels is not None and written is not None:
            if Path(written).resolve() == Path(source.labels).resolve():
                raise DataError(
                    f"--json {written} would overwrite the --labels table; write the "
                    "summary elsewhere"
                )

        ensemble, errors = member_ensemble(source, on_error)
        label = source.label
        named = source.label_from_name is not None or source.labels is not None
        if label is None and named and "label" in ensemble.conditions.columns:
            label = "label"  # what --label-from-name's group (or the table) names
        _check_label(ensemble, label, "the --members files")
        return ensemble, groups, extra, label, None, None, errors
    # a path or fsspec URL: streamed in batches, never loaded whole
    if "://" in str(source.ensemble):  # a missing backend: one line naming its package
        from pdmkit.ensembles import url_filesystem

        url_filesystem(str(source.ensemble))
    return str(source.ensemble), groups, extra, source.label, None, None, None


def member_ensemble(source: TableSource, on_error: str = "raise"):
    """The ensemble of a source's ``--members`` files, and the errors table.

    The files read by :func:`pdmkit.ensembles.read_members` with the source's reading
    options (``fs``, ``signals``, ``time``, ``label_from_name``, ``labels``,
    ``resample``, ``frame``, ``hop``): the one way the feature-table commands and
    ``pdmkit designer`` read member files.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import numpy as np
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> np.savez(d / "run1_ok.npz", vib=np.zeros(1000))
    >>> source = TableSource(members=[d], fs=100.0, label_from_name=r"_([a-z]+)",
    ...                      frame="2s", hop="500")
    >>> ens, errors = member_ensemble(source)
    >>> len(ens), ens.conditions["source_member"].unique().tolist(), len(errors)
    (2, ['run1_ok'], 0)
    """
    from pdmkit.ensembles import read_members

    if not source.members:
        raise DataError("member_ensemble reads --members files; the source names none")
    return read_members(
        source.members,
        fs=source.fs,
        signals=source.signals,
        time=source.time,
        label_from_name=source.label_from_name,
        labels=source.labels,
        resample=source.resample,
        frame=source.frame,
        hop=source.hop,
        on_error=on_error,
        return_errors=True,
        progress=source.progress,
    )


def _rate_arg(text: str) -> float:
    """``--resample``: a positive sampling rate in Hz."""
    try:
        rate = float(text)
    except ValueError:
        rate = math.nan
    if not (math.isfinite(rate) and rate > 0):
        raise argparse.ArgumentTypeError(
            f"expected a positive sampling rate in Hz (e.g. 12000); got {text!r}"
        )
    return rate


def add_member_options(
    parser: argparse.ArgumentParser, *, time_help: str | None = None
) -> None:
    """Add the flags that say how ``--members`` files are read (:data:`MEMBER_OPTIONS`).

    ``--fs``, ``--time``, ``--label-from-name``, ``--labels``, ``--resample``,
    ``--frame`` and ``--hop``, as ``pdmkit features / rank / classify / sensors`` and
    ``pdmkit designer`` spell them; their values are the :class:`TableSource` fields
    of the same names.

    Examples
    --------
    >>> import argparse
    >>> p = argparse.ArgumentParser()
    >>> add_member_options(p)
    >>> args = p.parse_args(["--frame", "0.1s", "--hop", "512", "--resample", "12000"])
    >>> args.frame, args.hop, args.resample, args.fs
    ('0.1s', '512', 12000.0, None)
    """
    parser.add_argument(
        "--fs",
        type=float,
        metavar="HZ",
        help="sampling rate of the --members files that state none (no time column, fs "
        "variable or fs column of --labels); without --resample also the rate every "
        "file must have (default: the rate most files state)",
    )
    parser.add_argument(
        "--time",
        metavar="COL",
        help=time_help
        or "the time column (seconds or timestamps) of the --members tables when it is "
        "not named time",
    )
    parser.add_argument(
        "--label-from-name",
        metavar="REGEX",
        help="take each --members file's label from its name: the one group of REGEX "
        "becomes the condition 'label' (e.g. '^\\d+_([A-Za-z]+)'), named groups "
        "(?P<fault>...) conditions of their names ((?P<fs>...): its sampling rate)",
    )
    parser.add_argument(
        "--labels",
        type=Path,
        metavar="TABLE",
        help="CSV/Parquet table of the --members files' conditions: a column file (or "
        "member) naming each file, the label / condition columns beside it (a column "
        "fs: each file's sampling rate in Hz)",
    )
    parser.add_argument(
        "--resample",
        type=_rate_arg,
        metavar="HZ",
        help="resample every --members file to this rate (polyphase, anti-aliased); "
        "files at different rates are an error without it",
    )
    parser.add_argument(
        "--frame",
        metavar="LENGTH",
        help="cut every --members file into frames of LENGTH samples (2048) or seconds "
        "(0.1s, 100ms; rounded to whole samples); each frame is a member, with the "
        "conditions source_member (its file) and frame",
    )
    parser.add_argument(
        "--hop",
        metavar="H",
        help="distance between frame starts, samples or seconds (default: --frame, no "
        "overlap); needs --frame",
    )


def _bearing_options(source: TableSource) -> dict:
    """``{"bearing": ..., "shaft_hz": ...}`` from --bearing and --shaft-hz (or {})."""
    spec, shaft = source.bearing, source.shaft_hz
    if spec is None and shaft is None:
        return {}
    if spec is None or shaft is None:
        given, missing = ("--bearing", "--shaft-hz")
        if spec is None:
            given, missing = missing, given
        raise DataError(
            f"{given} needs {missing}: the envelope indicators need the bearing "
            "(e.g. --bearing 6205) and the shaft speed (--shaft-hz 29.95, rpm / 60, or "
            "a condition column holding each member's)"
        )
    from pdmkit.features import BearingGeometry

    try:
        speed: float | str = float(shaft)
    except ValueError:
        speed = shaft  # a condition column, checked by the extraction
    else:
        if not math.isfinite(speed) or speed <= 0:
            raise DataError(
                f"--shaft-hz must be a positive shaft speed in Hz (rpm / 60) or a "
                f"condition column; got {shaft!r}"
            )
    return {"bearing": BearingGeometry.parse(spec), "shaft_hz": speed}


def _envelope_group(groups: tuple, options: dict, source: TableSource) -> tuple:
    """``groups`` with "envelope" added for --bearing; refuse envelope without one."""
    if source.bearing is not None and "envelope" not in groups:
        if source.groups:
            raise DataError(
                f"--bearing sets up the envelope group, which --groups {' '.join(groups)} "
                "leaves out; add envelope to --groups (or leave --groups out)"
            )
        groups = (*groups, "envelope")
    if "envelope" in groups and "bearing" not in options:
        raise DataError(
            "the envelope group needs the bearing and the shaft speed: pass --bearing "
            "(a name such as 6205, or n_balls=9,ball_d=7.94mm,pitch_d=39.04mm,angle=0) "
            "and --shaft-hz (rpm / 60)"
        )
    return groups


def _check_label(ensemble, label: str | None, where: str) -> None:
    """A --label that names no condition of the ensemble is an error before any work."""
    if label is None or not hasattr(ensemble, "conditions"):
        return
    columns = [str(c) for c in ensemble.conditions.columns]
    if label not in columns:
        raise DataError(
            f"--label {label!r} is not a condition of {where}; its conditions are "
            f"{columns}{did_you_mean(label, columns)}"
        )


def feature_table(source: TableSource, common: bool = True):
    """Return (table, label, sensors, features) for the input the user named.

    ``features`` lists the indicator columns ``classify``/``rank`` use by default:
    without ``--signals`` and with ``common``, those of the signals every member has
    (:func:`_common_signals`; ``sensors`` scores each sensor on the members that
    have it, and passes ``common=False``).
    """
    if source.features is not None:
        from pdmkit.ensembles import read_table

        for flag in ("label_from_name", "labels", "bearing", "shaft_hz"):
            if getattr(source, flag) is not None:
                name = "--" + flag.replace("_", "-")
                raise DataError(
                    f"{name} applies to --members files (the indicators of a "
                    "--features table are extracted already); give the member files "
                    "with --members"
                )
        table = read_table(source.features)
        return table, source.label, None, _indicator_columns(table, source.signals, common)
    ensemble, groups, options, label, sensors, profile, skipped = extraction_input(
        source, on_error="skip"
    )
    from pdmkit.features import extract_ensemble

    if skipped is not None and len(skipped):  # one bad file must not cost the others
        warnings.warn(
            f"{skipped['member'].nunique()} member file(s) skipped for bad input, e.g. "
            f"{skipped['error'].iloc[0]}",
            DataWarning,
            stacklevel=2,
        )
    size = f"{len(ensemble)} members" if not isinstance(ensemble, str) else ensemble
    say(f"extracting {', '.join(groups)} indicators from {size}")
    batch = {}
    if not isinstance(ensemble, str) and len(ensemble) > 1:
        # about 20 steps for the progress bar (each batch is still vectorised)
        batch = {"batch_size": max(1, math.ceil(len(ensemble) / 20))}
    table = extract_ensemble(
        ensemble, groups=groups, progress=source.progress, **batch, **options
    )
    if not isinstance(ensemble, str):  # the rates the indicators were computed at
        table.attrs["fs"] = {str(k): float(v) for k, v in ensemble.fs.items()}
    if label is not None and label in table.columns and table[label].isna().any():
        unlabelled = table.index[table[label].isna()]
        warnings.warn(
            f"{len(unlabelled)} member(s) have no {label!r} and are left out, e.g. "
            f"{list(map(str, unlabelled[:3]))}",
            DataWarning,
            stacklevel=2,
        )
        table = table[table[label].notna()]
    signals = source.signals
    if signals is None and profile is not None:
        signals = profile.classify_signals
    return table, label, sensors, _indicator_columns(table, signals, common)


def _indicator_columns(
    table: pd.DataFrame, signals: Sequence[str] | None, common: bool = True
) -> list[str]:
    columns = [c for c in table.columns if "/" in str(c)]
    if signals is None:
        return _common_signals(table, columns) if common else columns
    chosen = [c for c in columns if str(c).split("/")[0] in set(signals)]
    if not chosen:
        found = sorted({str(c).split("/")[0] for c in columns})
        raise DataError(
            f"no indicators of signals {list(signals)} in the table; found {found}"
        )
    return chosen


def _common_signals(table: pd.DataFrame, columns: list) -> list:
    """The indicator ``columns`` of the signals every member (row) has.

    A member without a signal has none of its indicators (all NaN); a signal that
    only some members have would leave the others without finite features, so its
    indicators are left out, with a DataWarning naming it and the members lacking it.
    A signal no member has whole stays (the classifier's error names it).
    """
    by_signal: dict[str, list] = {}
    for c in columns:
        by_signal.setdefault(str(c).split("/")[0], []).append(c)
    partial = {}
    for signal, cols in by_signal.items():
        lacking = table[cols].isna().all(axis=1).to_numpy()
        if lacking.any() and not lacking.all():
            partial[signal] = table.index[lacking]
    if not partial:
        return columns
    if len(partial) == len(by_signal):
        raise DataError(
            f"no signal is present in every member: {sorted(partial)} are each missing "
            "from some members; pass --signals NAME to use one (the members without it "
            "are left out), or give members that share their signals"
        )
    for signal, lacking in partial.items():
        shown = [str(m) for m in lacking[:3]] + (["..."] if len(lacking) > 3 else [])
        warnings.warn(
            f"signal {signal!r} is missing from {len(lacking)} of {len(table)} members "
            f"({', '.join(shown)}); its indicators are left out, as those members would "
            f"have none. Pass --signals naming {signal!r} to use it (the members without "
            "it are then left out)",
            DataWarning,
            stacklevel=4,  # the command that chose the features
        )
    return [c for c in columns if str(c).split("/")[0] not in partial]


def require_label(table: pd.DataFrame, label: str | None) -> str:
    if label is None:
        candidates = [c for c in table.columns if "/" not in str(c)]
        raise DataError(
            f"no --label given; name the condition column that holds the class "
            f"(columns without '/' in this table: {candidates})"
        )
    if label not in table.columns:
        raise DataError(
            f"label column {label!r} is not in the feature table; "
            f"condition columns found: {[c for c in table.columns if '/' not in str(c)]}"
        )
    return label


def parse_sensors(items: Sequence[str] | None, table: pd.DataFrame, default):
    if items:
        sensors = {}
        for item in items:
            name, sep, signals = item.partition("=")
            if not sep or not signals:
                raise DataError(f"--sensor {item!r}: expected NAME=SIGNAL[,SIGNAL...]")
            sensors[name] = [s for s in signals.split(",") if s]
        return sensors
    if default:
        return default
    signals = sorted(
        {str(c).split("/")[0] for c in table.columns if str(c).count("/") >= 2}
    )
    if not signals:
        raise DataError(
            "cannot tell the sensors apart: feature columns are not named "
            "<signal>/<group>/<Feature>; pass --sensor NAME=SIGNAL[,SIGNAL...]"
        )
    return {s: [s] for s in signals}


#: Column names that order members or rows in time, when --order / --time name none.
_ORDER_NAMES = ("time", "timestamp", "datetime", "date", "cycle")


def order_column(
    table: pd.DataFrame, source: TableSource, order: str | None = None
) -> str | None:
    """The column that orders the table's rows in time, or None (the order given).

    ``--order``, else ``--time`` for a ``--features`` table, else a condition column
    named time / timestamp / datetime / date / cycle, else a first column without a
    name that holds timestamps (a table pandas wrote with its time index, as the IMS
    feature files are).
    """
    columns = [str(c) for c in table.columns]
    given = order
    flag = "--order"
    if given is None and source.features is not None:
        given, flag = source.time, "--time"
    if given is not None:
        if given not in columns:
            conditions = [c for c in columns if "/" not in c]
            raise DataError(
                f"{flag} {given!r} is not a column of the feature table; its columns "
                f"without '/' are {conditions}{did_you_mean(given, conditions)}"
            )
        return given
    lower = {c.lower(): c for c in columns if "/" not in c}
    found = next((lower[n] for n in _ORDER_NAMES if n in lower), None)
    if found is not None:
        return found
    first = columns[0] if columns else ""
    if first.startswith("Unnamed: ") and not pd.api.types.is_numeric_dtype(table[first]):
        if parse_timestamps(table[first]).notna().all():
            return first
    return None
