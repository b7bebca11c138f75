"""The ``pdmkit`` command line.

Every sub-command writes its results as data (Parquet / JSON) and a self-contained HTML
report into ``--out DIR``, beside whatever the folder already holds: only the command's
own files are replaced, all of one run at once (:mod:`pdmkit._outputs`);
``--json PATH`` writes the machine-readable summary anywhere but in pdmkit's own
``.pdmkit`` folders. Errors in the input, and usage errors (an unknown option, a missing
or bad argument), end the command with exit status 2 and one line on stderr that names
the problem; results already written are never half-overwritten.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

import pandas as pd

from pdmkit._outputs import OutputRun, check_output_folder, collect_warnings
from pdmkit.errors import DataError, ModelError, did_you_mean
from pdmkit.experiments._report import _readable_float
from pdmkit.experiments.designer import add_parser as add_designer_parser
from pdmkit.experiments.studies import STUDIES

__all__ = ["main"]


# --------------------------------------------------------------------------- helpers

#: ``identify --structure`` choices shown by ``--help``, named here so that the help
#: does not import the models (a test checks they are ``IDENTIFY_STRUCTURES``' keys)
IDENTIFY_CHOICES = ("ar", "arx", "armax", "oe", "bj", "n4sid", "hw", "fractional")


def _seconds(table, path):
    """The table with a timestamp time column in seconds (said once, with its origin)."""
    from pdmkit.experiments._rul import units_in_seconds

    table, origin = units_in_seconds(table, path)
    if origin is not None:  # converted: the table has "time", else "cycle"
        name = "time" if "time" in table.columns else "cycle"
        _say(f"{path}: time column {name!r} holds timestamps: seconds since {origin}")
    return table


def _say(message: str) -> None:
    print(f"pdmkit: {message}", file=sys.stderr, flush=True)


def _input_paths(args: argparse.Namespace) -> list:
    """The files and folders a command reads (never to be overwritten by its output)."""
    names = ["members", "ensemble", "costs", "data", "model_file", "validation"]
    names += ["train", "test", "trained", "history"]
    if args.command != "rul":  # rul's --features names columns
        names.append("features")
    paths = []
    for name in names:
        value = getattr(args, name, None)
        if isinstance(value, list | tuple):
            paths += list(value)
        elif value is not None:
            paths.append(value)
    return paths


def _output_run(args: argparse.Namespace, command: str) -> OutputRun:
    """The run that writes ``command``'s files into ``--out`` (checked before any work)."""
    return OutputRun(args.out, command, inputs=_input_paths(args), json_path=args.json)


def _finish(run: OutputRun, summary: dict, report, name: str, then=None) -> None:
    """Register the JSON summary and the report with the run and commit it."""
    run.add_json(f"{name}.json", summary)
    run.add_report("report.html", report)
    run.commit(then)
    _say(f"wrote {run.path(f'{name}.json')} and {run.path('report.html')}")


# --------------------------------------------------------------------------- inputs
def _add_input_options(
    parser: argparse.ArgumentParser, *, features_ok: bool = True
) -> None:
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--dataset", help="named dataset (see `pdmkit datasets`), e.g. cwru"
    )
    source.add_argument(
        "--ensemble",
        help="Parquet ensemble directory, or its fsspec URL (s3://..., file://...)",
    )
    source.add_argument(
        "--members",
        nargs="+",
        metavar="FILE",
        help="member files, one recording each (CSV/Parquet with a time column, "
        ".mat/.npz with an fs variable; folders and glob patterns too)",
    )
    if features_ok:
        source.add_argument(
            "--features", type=Path, help="feature table (Parquet, CSV or text)"
        )
    parser.add_argument(
        "--fs",
        type=float,
        metavar="HZ",
        help="sampling rate of --members files (default: the rate most files state)",
    )
    parser.add_argument("--label", help="condition column holding the class label")
    parser.add_argument(
        "--groups",
        nargs="+",
        default=None,
        help="indicator groups to extract (default: the dataset's, else stats spectral)",
    )
    parser.add_argument(
        "--signals",
        nargs="+",
        default=None,
        help="use only these signals' indicators (default: the dataset's choice, else all)",
    )
    parser.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an indicator-group option (repeat), e.g. ar_order=12, nperseg=2048, "
        "frf_input=Force (a model group's input signal)",
    )
    parser.add_argument(
        "--time",
        metavar="COL",
        help="the time column (seconds or timestamps) when it is not named time: of "
        "the --members tables, or of the --features table (rank, classify --split time)",
    )
    parser.add_argument(
        "--label-from-name",
        metavar="REGEX",
        help="take each --members file's label from its name: the one group of REGEX "
        "becomes the condition 'label' (e.g. '^\\d+_([A-Za-z]+)'), named groups "
        "(?P<fault>...) conditions of their names",
    )
    parser.add_argument(
        "--labels",
        type=Path,
        metavar="TABLE",
        help="CSV/Parquet table of the --members files' conditions: a column file (or "
        "member) naming each file, the label / condition columns beside it",
    )
    parser.add_argument(
        "--bearing",
        metavar="SPEC",
        help="bearing of the envelope indicators: a name (6205, 6203, ZA-2115; see "
        "docs/inputs.md) or n_balls=9,ball_d=7.94mm,pitch_d=39.04mm,angle=0 (mm, cm, m, "
        "in); adds the envelope group",
    )
    parser.add_argument(
        "--shaft-hz",
        metavar="HZ|COL",
        help="shaft speed in Hz (rpm / 60) for --bearing, or the condition column "
        "holding each member's",
    )
    parser.add_argument(
        "--quiet", action="store_true", help="no progress bars (they show on a terminal)"
    )
    parser.add_argument("--out", type=Path, default=Path("results"), help="output folder")
    parser.add_argument("--json", type=Path, help="also write the JSON summary here")


def _group_options(
    items: Sequence[str], flag: str = "--option", example: str = "ar_order=12"
) -> dict:
    """``["ar_order=12", "frf_input=Force"]`` -> ``{"ar_order": 12, "frf_input": "Force"}``.

    Values are read as JSON where they parse (numbers, lists, true/false, null),
    otherwise kept as text (a signal name).
    """
    options = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise DataError(f"{flag} takes KEY=VALUE, e.g. {example}; got {item!r}")
        try:
            value = json.loads(text)
        except ValueError:
            value = text
        options[key.strip()] = value
    return options


def _extraction_input(args: argparse.Namespace, on_error: str = "raise"):
    """(ensemble or path/URL, groups, options, label, sensors, profile, read errors)."""
    from pdmkit.experiments._datasets import get_profile
    from pdmkit.features import GROUPS, check_group_options, check_groups, group_of_option

    groups = tuple(args.groups) if args.groups else ("stats", "spectral")
    extra = _group_options(getattr(args, "option", []) or [])
    try:  # a misspelt group or --option is an input error (exit 2), before loading
        if args.groups:
            check_groups(args.groups)
        check_group_options(GROUPS, extra, where="pdmkit --option")
    except TypeError as exc:
        raise DataError(str(exc)) from None
    extra = {**extra, **_bearing_options(args)}
    members = getattr(args, "members", None)
    for flag, value in (
        ("--label-from-name", getattr(args, "label_from_name", None)),
        ("--labels", getattr(args, "labels", None)),
        ("--time", getattr(args, "time", None)),
    ):
        if value is not None and not members:
            raise DataError(
                f"{flag} applies to --members files (or, --time, to a --features "
                "table); give the member files with --members"
            )
    if args.dataset is not None:
        profile = get_profile(args.dataset)
        _say(f"loading dataset {profile.name!r}")
        ensemble = profile.load()
        groups = tuple(args.groups) if args.groups else profile.groups
        groups = _envelope_group(groups, {"bearing": None}, args)
        sensors = {k: list(v) for k, v in profile.sensors.items()}
        label = args.label or profile.label
        # the profile's defaults serve the groups chosen; the user's own must match
        defaults = {
            k: v for k, v in profile.options().items() if group_of_option(k) in groups
        }
        options = {**defaults, **extra}
        _check_label(ensemble, label, f"dataset {profile.name!r}")
        return ensemble, groups, options, label, sensors, profile, None
    groups = _envelope_group(groups, extra, args)
    if members:
        from pdmkit.ensembles import read_members

        written = getattr(args, "json", None)
        if args.labels is not None and written is not None:
            if Path(written).resolve() == Path(args.labels).resolve():
                raise DataError(
                    f"--json {written} would overwrite the --labels table; write the "
                    "summary elsewhere"
                )

        ensemble, errors = read_members(
            members,
            fs=args.fs,
            signals=args.signals,
            time=args.time,
            label_from_name=args.label_from_name,
            labels=args.labels,
            on_error=on_error,
            return_errors=True,
            progress=_progress_flag(args),
        )
        label = args.label
        named = args.label_from_name is not None or args.labels is not None
        if label is None and named and "label" in ensemble.conditions.columns:
            label = "label"  # what --label-from-name's group (or the table) names
        _check_label(ensemble, label, "the --members files")
        return ensemble, groups, extra, label, None, None, errors
    # a path or fsspec URL: streamed in batches, never loaded whole
    if "://" in str(args.ensemble):  # a missing backend: one line naming its package
        from pdmkit.ensembles import url_filesystem

        url_filesystem(str(args.ensemble))
    return str(args.ensemble), groups, extra, args.label, None, None, None


def _progress_flag(args: argparse.Namespace) -> bool | None:
    """Progress bars: off with --quiet, else on a terminal only (None)."""
    return False if getattr(args, "quiet", False) else None


def _bearing_options(args: argparse.Namespace) -> dict:
    """``{"bearing": ..., "shaft_hz": ...}`` from --bearing and --shaft-hz (or {})."""
    spec, shaft = getattr(args, "bearing", None), getattr(args, "shaft_hz", None)
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


def _envelope_group(groups: tuple, options: dict, args: argparse.Namespace) -> tuple:
    """``groups`` with "envelope" added for --bearing; refuse envelope without one."""
    if getattr(args, "bearing", None) is not None and "envelope" not in groups:
        if args.groups:
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


def _feature_table(args: argparse.Namespace, common: bool = True):
    """Return (table, label, sensors, features) for the input the user named.

    ``features`` lists the indicator columns ``classify``/``rank`` use by default:
    without ``--signals`` and with ``common``, those of the signals every member has
    (:func:`_common_signals`; ``sensors`` scores each sensor on the members that
    have it, and passes ``common=False``).
    """
    if getattr(args, "features", None) is not None:
        from pdmkit.ensembles import read_table

        for flag in ("label_from_name", "labels", "bearing", "shaft_hz"):
            if getattr(args, flag, None) is not None:
                name = "--" + flag.replace("_", "-")
                raise DataError(
                    f"{name} applies to --members files (the indicators of a "
                    "--features table are extracted already); give the member files "
                    "with --members"
                )
        table = read_table(args.features)
        return table, args.label, None, _indicator_columns(table, args.signals, common)
    ensemble, groups, options, label, sensors, profile, skipped = _extraction_input(
        args, on_error="skip"
    )
    from pdmkit.errors import DataWarning
    from pdmkit.features import extract_ensemble

    if skipped is not None and len(skipped):  # one bad file must not cost the others
        warnings.warn(
            f"{skipped['member'].nunique()} member file(s) skipped for bad input, e.g. "
            f"{skipped['error'].iloc[0]}",
            DataWarning,
            stacklevel=2,
        )
    size = f"{len(ensemble)} members" if not isinstance(ensemble, str) else ensemble
    _say(f"extracting {', '.join(groups)} indicators from {size}")
    batch = {}
    if not isinstance(ensemble, str) and len(ensemble) > 1:
        # about 20 steps for the progress bar (each batch is still vectorised)
        batch = {"batch_size": max(1, math.ceil(len(ensemble) / 20))}
    table = extract_ensemble(
        ensemble, groups=groups, progress=_progress_flag(args), **batch, **options
    )
    if label is not None and label in table.columns and table[label].isna().any():
        unlabelled = table.index[table[label].isna()]
        warnings.warn(
            f"{len(unlabelled)} member(s) have no {label!r} and are left out, e.g. "
            f"{list(map(str, unlabelled[:3]))}",
            DataWarning,
            stacklevel=2,
        )
        table = table[table[label].notna()]
    signals = args.signals
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
    from pdmkit.errors import DataWarning

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


def _require_label(table: pd.DataFrame, label: str | None) -> str:
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


def _parse_sensors(items: Sequence[str] | None, table: pd.DataFrame, default):
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


# --------------------------------------------------------------------------- commands
def _cmd_datasets(args: argparse.Namespace) -> int:
    from pdmkit.ensembles import DATASETS
    from pdmkit.experiments._datasets import PROFILES

    print("Datasets (loaders in pdmkit.ensembles):")
    for name, description in DATASETS.items():
        flag = "  [classify/sensors]" if name in PROFILES else ""
        print(f"  {name:16s} {description}{flag}")
    return 0


#: Exit status of a command that finished but left members out (bad input).
EXIT_SKIPPED = 3


def _cmd_features(args: argparse.Namespace) -> int:
    with _output_run(args, "features") as run:
        return _features(args, run)


def _features(args: argparse.Namespace, run: OutputRun) -> int:
    from pdmkit.experiments._report import Report
    from pdmkit.experiments._runs import extract_features_run, mark_run

    on_error = "raise" if args.strict else "skip"
    ensemble, groups, options, _, _, _, read_errors = _extraction_input(args, on_error)
    out = Path(args.out)
    client = args.scheduler if args.scheduler else args.workers
    where = (
        f"on the Dask scheduler {args.scheduler}"
        if args.scheduler
        else f"on {args.workers} local Dask workers"
        if args.workers
        else "in-process"
    )
    size = f"{len(ensemble)} members" if not isinstance(ensemble, str) else ensemble
    _say(f"extracting {', '.join(groups)} indicators from {size} {where}")
    run.open()  # hold OUT while its partition store (OUT/run) fills
    table, errors = extract_features_run(
        ensemble,
        out / "run",
        signals=args.signals,
        groups=groups,
        batch_size=args.batch_size,
        on_error=on_error,
        fresh=args.fresh,
        client=client,
        replace_stale=True,  # other settings: a failed run, or one saved to OUT, goes
        progress=_progress_flag(args),
        **options,
    )
    if read_errors is not None and len(read_errors):
        errors = pd.concat([read_errors, errors], ignore_index=True)
    run.add_parquet("features.parquet", table)
    run.add_parquet("errors.parquet", errors)
    feature_cols = [c for c in table.columns if "/" in str(c)]
    summary = {
        "n_members": len(table),
        "n_features": len(feature_cols),
        "features": feature_cols,
        "conditions": [c for c in table.columns if c not in feature_cols],
        "path": str(out / "features.parquet"),
        "n_skipped": int(errors["member"].nunique()),
        "errors": errors.to_dict(orient="records"),
        "errors_path": str(out / "errors.parquet"),
    }
    report = Report("pdmkit features")
    report.add_text(
        f"{summary['n_members']} members, {summary['n_features']} condition indicators."
    )
    if len(errors):
        report.add_text(
            f"{summary['n_skipped']} member(s) were left out for bad input; "
            "see the table below (also in errors.parquet)."
        )
        report.add_table(errors, caption="Members left out")
    report.add_table(table[feature_cols].describe().T, caption="Indicator statistics")

    def saved() -> None:  # under OUT's lock: the store's results are in OUT now
        mark_run(out / "run", "saved", run.id)

    _finish(run, summary, report, "features", saved)
    if len(errors):
        _say(
            f"{summary['n_skipped']} member(s) skipped for bad input, e.g. "
            f"{errors['error'].iloc[0]}; see {out / 'errors.parquet'} (exit status "
            f"{EXIT_SKIPPED}; --strict stops at the first)"
        )
        return EXIT_SKIPPED
    return 0


def _add_scale_options(parser: argparse.ArgumentParser) -> None:
    cluster = parser.add_mutually_exclusive_group()
    cluster.add_argument(
        "--workers",
        type=_positive_int,
        metavar="N",
        help="run on a local Dask cluster of N worker processes (default: in-process)",
    )
    cluster.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on the Dask cluster at ADDRESS, e.g. tcp://10.0.0.5:8786",
    )
    parser.add_argument(
        "--batch-size",
        type=_positive_int,
        default=512,
        metavar="N",
        help="members per partition (one task, one committed result; default 512)",
    )
    parser.add_argument(
        "--fresh",
        action="store_true",
        help="discard the partitions a previous run left in OUT/run and start over",
    )
    parser.add_argument(
        "--strict",
        action="store_true",
        help="stop at the first member with bad data (default: skip it, report it, "
        f"exit with status {EXIT_SKIPPED})",
    )


def _number(convert, ok, what: str):
    """An argparse ``type`` that reads a number with ``convert`` and checks ``ok``."""

    def parse(text: str):
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not ok(value):
            raise argparse.ArgumentTypeError(f"expected {what}, got {value:g}")
        return value

    parse.__name__ = what
    return parse


_fraction = _number(float, lambda v: 0 < v < 1, "a number in (0, 1)")
_positive_int = _number(int, lambda v: v >= 1, "a positive integer")
_positive_seconds = _number(
    float, lambda v: v > 0 and math.isfinite(v), "a positive number of seconds"
)


def _ranking(table: pd.DataFrame, label: str, method: str, features: list[str]):
    from pdmkit.features import rank_features

    return rank_features(table, table[label], method=method, features=features)


def _cmd_rank(args: argparse.Namespace) -> int:
    with _output_run(args, "rank") as run:
        return _rank(args, run)


#: Column names that order members or rows in time, when --order / --time name none.
_ORDER_NAMES = ("time", "timestamp", "datetime", "date", "cycle")


def _order_column(table: pd.DataFrame, args: argparse.Namespace) -> str | None:
    """The column that orders the table's rows in time, or None (the order given).

    ``--order``, else ``--time`` for a ``--features`` table, else a condition column
    named time / timestamp / datetime / date / cycle, else a first column without a
    name that holds timestamps (a table pandas wrote with its time index, as the IMS
    feature files are).
    """
    columns = [str(c) for c in table.columns]
    given = getattr(args, "order", None)
    flag = "--order"
    if given is None and getattr(args, "features", None) is not None:
        given, flag = getattr(args, "time", None), "--time"
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
        from pdmkit._checks import parse_timestamps

        if parse_timestamps(table[first]).notna().all():
            return first
    return None


def _clock_columns(table, ranked, unit: str | None, order: str | None) -> None:
    """Warn about top-ranked columns that step with the row order itself.

    A clock or a counter (a snapshot's time of day, a cycle count) is monotonic before
    any smoothing, which no noisy health indicator is: the same monotonicity, on the raw
    rows, at 0.98 or more (99 % of the steps one way).
    """
    import warnings

    from pdmkit.errors import DataWarning
    from pdmkit.features import rank_features

    top = [f for f in ranked["feature"].head(10) if f != order]
    raw = rank_features(table, method="monotonicity", features=top, unit=unit, time=order)
    for row in raw.to_pandas().itertuples():
        if row.score >= 0.98:
            warnings.warn(
                f"{row.feature!r} is monotonic in the raw rows ordered by "
                f"{order or 'the row number'!r} (monotonicity {row.score:.3f} before "
                "smoothing): a clock or a counter, not a health indicator; leave it out "
                "with --features",
                DataWarning,
                stacklevel=2,
            )


def _rank(args: argparse.Namespace, run: OutputRun) -> int:
    from pdmkit.experiments._report import Report
    from pdmkit.features import rank_features

    table, label, _, features = _feature_table(args)
    if args.method in ("kruskal", "anova"):
        for flag in ("unit", "window"):
            if getattr(args, flag) is not None:
                raise DataError(
                    f"--{flag} is for the prognostic methods (monotonicity, "
                    f"trendability, prognosability), not --method {args.method}"
                )
        label = _require_label(table, label)
        ranking = _ranking(table, label, args.method, features)
        described = {"label": label}
    else:
        if args.unit is not None and args.unit not in table.columns:
            conditions = [str(c) for c in table.columns if "/" not in str(c)]
            raise DataError(
                f"--unit {args.unit!r} is not a column of the feature table; its "
                f"columns without '/' are {conditions}"
                f"{did_you_mean(args.unit, conditions)}"
            )
        unit = args.unit if args.unit is not None else None
        if unit is None and "unit" in table.columns:
            unit = "unit"
        order = _order_column(table, args)
        units = table[unit].nunique() if unit is not None else 1
        by = f"{order!r}"
        if order is not None and order.startswith("Unnamed: "):
            by = "the unnamed first column (timestamps)"
        _say(
            f"{args.method}: {units} unit(s)"
            + (f" told apart by {unit!r}" if unit is not None else " (no --unit column)")
            + (f", rows ordered by {by}" if order else ", rows in the order given")
            + (f", smoothed over {args.window} rows" if args.window else "")
        )
        ranking = rank_features(
            table,
            method=args.method,
            features=features or None,
            unit=unit,
            time=order,
            window=args.window,
        )
        described = {"unit": unit, "time": order, "n_units": int(units)}
        described["window"] = args.window
        _clock_columns(table, ranking.to_pandas(), unit, order)
    ranked = ranking.to_pandas()
    run.add_parquet("ranking.parquet", ranked)
    summary = {
        "method": args.method,
        **described,
        "ranking": ranked.head(args.top).to_dict(orient="records"),
    }
    report = Report(f"pdmkit rank ({args.method})")
    report.add_figure(ranking.plot(k=min(args.top, 30)), caption="Ranked indicators")
    report.add_table(ranked.head(args.top), caption=f"Top {args.top} indicators")
    _finish(run, summary, report, "ranking")
    return 0


def _cmd_classify(args: argparse.Namespace) -> int:
    with _output_run(args, "classify") as run:
        return _classify(args, run)


def _classify(args: argparse.Namespace, run: OutputRun) -> int:
    from pdmkit.experiments._classify import classify
    from pdmkit.experiments._report import Report

    table, label, _, features = _feature_table(args)
    label = _require_label(table, label)
    order = None
    if args.split == "time":
        order = _order_column(table, args)
    elif args.order is not None:
        raise DataError("--order orders the members for --split time; give that too")
    result = classify(
        table,
        label,
        features=features,
        model=args.model,
        top_k=args.top_k,
        selection=args.selection,
        test_size=args.test_size,
        random_state=args.seed,
        split=args.split,
        order=order,
        progress=_progress_flag(args),
    )
    summary = result.summary()
    split_note = next((n for n in result.notes if n.startswith("time split")), None)
    if split_note is not None:
        _say(split_note)
    _say(f"held-out accuracy {summary['accuracy']:.4f} ({args.model}, top {args.top_k})")
    report = Report(f"pdmkit classify ({args.model})")
    report.add_text(
        f"Held-out accuracy {summary['accuracy']:.4f} on {summary['n_test']} members "
        f"(trained on {summary['n_train']}); selected indicators: "
        f"{', '.join(summary['features'])}."
    )
    if split_note is not None:
        report.add_text(split_note[0].upper() + split_note[1:] + ".")
    report.add_figure(result.plot(), caption="Confusion matrix (held-out part)")
    report.add_table(result.to_pandas(), caption="Per-class recall")
    if args.selection in ("kruskal", "anova"):
        report.add_figure(
            _ranking(table, label, args.selection, features).plot(k=20),
            caption="Indicator ranking",
        )
    _finish(run, summary, report, "classify")
    return 0


def _cmd_sensors(args: argparse.Namespace) -> int:
    with _output_run(args, "sensors") as run:
        return _sensors(args, run)


def _sensors(args: argparse.Namespace, run: OutputRun) -> int:
    from pdmkit.experiments._report import Report
    from pdmkit.experiments._sensors import compare_sensors, load_sensor_costs

    table, label, default_sensors, _ = _feature_table(args, common=False)
    label = _require_label(table, label)
    sensors = _parse_sensors(args.sensor, table, default_sensors)
    costs = load_sensor_costs(args.costs)
    comparison = compare_sensors(
        table,
        label,
        sensors,
        costs,
        model=args.model,
        top_k=args.top_k,
        random_state=args.seed,
        progress=_progress_flag(args),
    )
    summary = comparison.summary()
    report = Report("pdmkit sensors")
    frame = comparison.to_pandas()
    report.add_figure(
        comparison.plot(), caption="Accuracy against cost, Pareto front marked"
    )
    report.add_table(frame, caption="Sensors by accuracy (cross-validated) and cost")
    for sensor, note in zip(frame["sensor"], frame["note"], strict=True):
        if note:
            report.add_text(f"{sensor}: {note}")
    _finish(run, summary, report, "sensors")
    return 0


def _cmd_rul(args: argparse.Namespace) -> int:
    from pdmkit.experiments._rul import predict_rul, run_rul
    from pdmkit.experiments._rul_checks import cap_text

    if (args.trained is None) != (args.history is None):
        raise DataError("--trained MODEL and --history TABLE go together")
    if args.expect_sha256 is not None and args.trained is None:
        raise DataError("--expect-sha256 checks the file of --trained MODEL; give both")
    if args.trained is not None:
        answer = predict_rul(
            args.trained,
            args.history,
            json_path=args.json,
            expect_sha256=args.expect_sha256,
            unit=args.unit,
            time=args.time,
            time_unit=args.time_unit,
        )
        for row in answer["units"]:
            print(row["text"])
        return 0
    if args.test is not None and args.train is None:
        raise DataError("--test needs --train (the training units)")
    if args.train is None and (args.unit or args.time):
        raise DataError("--unit and --time name columns of --train/--test/--history")
    # before reading anything: --out must not overwrite --train / --test
    check_output_folder(args.out, "rul", inputs=_input_paths(args), json_path=args.json)
    dataset = args.dataset
    time_unit = args.time_unit
    if args.train is not None:
        from pdmkit.experiments._rul import split_run_to_failure

        train, guessed = _rul_table(args, args.train)
        time_unit = time_unit or guessed
        if args.test is None:  # hold out a quarter of the units, cut at random
            dataset = split_run_to_failure(train, seed=args.seed)
            _say(
                f"{args.train}: {dataset[1]['unit'].nunique()} of "
                f"{train['unit'].nunique()} units held out "
                "as test histories, each cut at 10-90 % of its life"
            )
        else:
            dataset = (train, _rul_table(args, args.test)[0])
    summary = run_rul(
        dataset,
        args.model,
        out_dir=args.out,
        json_path=args.json,
        seed=args.seed,
        rul_cap=args.rul_cap,
        features=args.features,
        options=_group_options(args.option, example="k=5"),
        dataset_options=_group_options(
            args.dataset_option, "--dataset-option", "walk_shape=16"
        )
        or None,
        calibrate=args.calibrate,
        time_unit=time_unit,
    )
    u = summary.get("time_unit", "")
    capped = cap_text(summary.get("rul_cap"), u, summary.get("rul_cap_source", ""))
    n_warn = len(summary.get("warnings", []))
    _say(
        f"{summary['model']}: RMSE {summary['rmse']:.2f} {u}, MAE {summary['mae']:.2f} "
        f"{u}, PHM08 score {_readable_float(summary['phm08_score'])}, "
        f"{100 * summary['level']:g} % interval coverage {summary['coverage']:.2f} on "
        f"{summary['n_units']} units; {capped}; time unit {u}"
        + (f"; {n_warn} warning(s), listed in rul.json" if n_warn else "")
        + f"; see {args.out}/report.html; trained model {summary['model_file']} "
        f"(sha256 {summary['model_sha256']}: keep it to check the file later with "
        "--expect-sha256)"
    )
    return 0


_RUL_TIME_UNITS = {
    "cycle": "cycles",
    "cycles": "cycles",
    "s": "s",
    "sec": "s",
    "second": "s",
    "seconds": "s",
    "min": "min",
    "minute": "min",
    "minutes": "min",
    "h": "h",
    "hour": "h",
    "hours": "h",
    "d": "d",
    "day": "d",
    "days": "d",
}


def _rul_table(args: argparse.Namespace, path) -> tuple[pd.DataFrame, str]:
    """A --train/--test table with its --unit/--time columns renamed to unit/time.

    Timestamps are in seconds. Returned with the time unit the table implies (said when
    guessed).
    """
    import re

    from pdmkit.ensembles import read_table
    from pdmkit.experiments._rul import units_in_seconds
    from pdmkit.experiments._rul_checks import rename_keys

    table = read_table(path)
    if getattr(args, "wide", None):
        table = _long_from_wide(table, path, args.time, args.wide, args.unit)
    if args.time is not None and args.time not in table.columns:
        raise DataError(
            f"{path}: --time {args.time!r} is not a column (columns: "
            f"{list(table.columns)[:12]})"
        )
    table, origin = units_in_seconds(table, path, args.time)
    name = args.time or ("time" if "time" in table.columns else "cycle")
    if origin is not None:
        _say(f"{path}: time column {name!r} holds timestamps: seconds since {origin}")
        guessed = "s"
    else:
        words = [w for w in re.split(r"[^a-z]+", str(name).lower()) if w]
        guessed = next((_RUL_TIME_UNITS[w] for w in words if w in _RUL_TIME_UNITS), "s")
        if args.time_unit is None and args.time is not None and path == args.train:
            _say(
                f"{path}: time column {name!r} read as {guessed} (from its name); "
                "--time-unit says otherwise"
            )
    table = rename_keys(
        table, path, [(args.unit, "unit", "--unit"), (args.time, "time", "--time")]
    )
    return table, guessed


def _long_from_wide(
    table: pd.DataFrame, path, time: str | None, name: str, unit
) -> pd.DataFrame:
    """A wide run-to-failure table as the long one ``rul`` reads.

    The wide table has a time column and one column per unit; the long one has ``unit`` (the
    column's name), the time column and ``name``.
    """
    if unit is not None:
        raise DataError(f"{path}: --wide takes the units from the columns; drop --unit")
    given = time
    time = table.columns[0] if time is None else time
    if time not in table.columns:
        raise DataError(
            f"{path}: --time {time!r} is not a column (columns: {list(table.columns)[:12]})"
        )
    units = [c for c in table.columns if c != time]
    if not units:
        raise DataError(f"{path}: --wide needs a time column and one column per unit")
    if name in (time, "unit"):
        raise DataError(f"{path}: --wide {name!r} clashes with the time or unit column")
    long = table.melt(id_vars=[time], value_vars=units, var_name="unit", value_name=name)
    if given is None:  # the first column, whatever its header: the time
        long = long.rename(columns={time: "time"})
        time = "time"
    _say(
        f"{path}: wide table read as {len(units)} units ({', '.join(map(str, units[:6]))}"
        f"{', ...' if len(units) > 6 else ''}), indicator {name!r} over {time!r}"
    )
    return long.dropna(subset=[name]).sort_values(["unit", time], kind="stable")


def _rul_cap(text: str) -> float | str | None:
    """``--rul-cap N`` (a positive number), ``none``, or ``convention`` (default)."""
    if text.strip().lower() in ("none", "no", "off"):
        return None
    if text.strip().lower() == "convention":
        return "convention"
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a positive number or none, got {text!r}"
        ) from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def _cmd_mismatch(args: argparse.Namespace) -> int:
    from pdmkit.experiments._mismatch import run_mismatch

    effects = None
    if args.effects:
        effects = [e.strip() for e in args.effects.split(",") if e.strip()]
    summary = run_mismatch(
        args.model_file,
        args.data,
        validation_path=args.validation,
        out_dir=args.out,
        json_path=args.json,
        effects=effects,
        model_timeout=args.model_timeout,
        input_hold=args.input_hold,
        max_seconds=args.max_seconds,
    )
    verdict = summary["verdict"]
    fit = summary["fit"]
    target = f" on {verdict['target']}" if verdict["target"] else ""
    target += "".join(f" + {a['effect']} on {a['target']}" for a in verdict.get("also", []))
    _say(
        f"verdict: {verdict['effect']}{target}; validation RMSE "
        f"{fit['rmse_nominal']:.4g} -> {fit['rmse_augmented']:.4g}. "
        f"{verdict['physics']} See {args.out}/report.html"
    )
    return 0


def _cmd_identify(args: argparse.Namespace) -> int:
    from pdmkit.experiments._identify import format_fit, format_hz, run_identify

    summary = run_identify(
        args.data,
        input=args.input,
        output=args.output,
        structure=args.structure,
        order=args.order,
        out_dir=args.out,
        json_path=args.json,
        fs=args.fs,
        criterion=args.criterion,
        band=args.band,
        decimate=args.decimate,
    )
    for key in ("decimation", "band", "order_search"):
        part = summary.get(key) or {}
        if part.get("note") and not part.get("at_edge"):  # at the edge: a warning
            _say(part["note"])
    modes = format_hz(summary.get("natural_frequencies_hz"))
    dropped = len(summary.get("not_modes") or [])
    _say(
        f"{summary['structure']} {summary['order']}: fit "
        f"{format_fit(summary.get('fit_percent'), 1)}"
        f"{' in the band' if summary.get('band') else ''}"
        f"{'; modes ' + modes if modes else ''}"
        f"{f' ({dropped} pole(s) that are not modes in not_modes)' if dropped else ''}"
        f"; see {args.out}/report.html"
    )
    return 0


def _cmd_study(args: argparse.Namespace) -> int:
    from pdmkit.experiments.studies import run_study

    out = args.out if args.out is not None else Path("results/study") / args.name
    start = time.perf_counter()
    run_study(args.name, out, json_path=args.json, seed=args.seed, quick=args.quick)
    seconds = time.perf_counter() - start
    _say(f"{args.name} finished in {seconds:.0f} s; see {out}/report.html")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from pdmkit.experiments._demo import run_demo

    start = time.perf_counter()
    run_demo(
        args.out,
        members=args.members,
        seed=args.seed,
        recording_s=args.recording_s,
        json_path=args.json,
    )
    _say(
        f"demo finished in {time.perf_counter() - start:.0f} s; see {args.out}/report.html"
    )
    return 0


# --------------------------------------------------------------------------- parser
class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line on stderr, exit status 2.

    The line names the sub-command, the argument and what is wrong, and points to the
    sub-command's ``--help`` (argparse's own prints the whole usage block first). An
    unknown option is charged to the sub-command it was given to, with the nearest
    option when one is close. ``--help`` is argparse's, unchanged.
    """

    def error(self, message: str) -> NoReturn:
        text = " ".join(line.strip() for line in str(message).splitlines())
        self.exit(2, f"{self.prog}: error: {text} (see {self.prog} --help)\n")

    def parse_args(self, args=None, namespace=None):  # type: ignore[override]
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            parser = self._chosen(parsed)
            unknown = next((e for e in extras if e.startswith("-")), "")
            hint = did_you_mean(unknown.split("=")[0], parser._option_string_actions)
            parser.error(f"unrecognized arguments: {' '.join(extras)}{hint}")
        return parsed

    def _chosen(self, parsed: argparse.Namespace) -> argparse.ArgumentParser:
        """The parser of the sub-command ``parsed`` names (else this one)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                chosen = action.choices.get(getattr(parsed, action.dest, None))
                if isinstance(chosen, _Parser):
                    return chosen._chosen(parsed)
        return self


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of the ``pdmkit`` command."""
    from pdmkit import __version__

    parser = _Parser(
        prog="pdmkit",
        description="Predictive-maintenance workbench: indicators, ranking, fault "
        "classifiers, sensor comparison.",
    )
    parser.add_argument("--version", action="version", version=f"pdmkit {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("datasets", help="list the named datasets")
    p.set_defaults(func=_cmd_datasets)

    p = sub.add_parser("features", help="extract condition indicators")
    _add_input_options(p, features_ok=False)
    _add_scale_options(p)
    p.set_defaults(func=_cmd_features)

    p = sub.add_parser("rank", help="rank condition indicators")
    _add_input_options(p)
    p.add_argument(
        "--method",
        default="kruskal",
        choices=["kruskal", "anova", "monotonicity", "trendability", "prognosability"],
        help="kruskal, anova: separate the --label classes; monotonicity, "
        "trendability, prognosability (Coble & Hines): track degradation over the "
        "run-to-failure rows of each --unit, ordered by --order/--time",
    )
    p.add_argument(
        "--unit",
        metavar="COL",
        help="prognostic methods: the column telling run-to-failure units apart "
        "(default: unit, else all rows form one unit)",
    )
    p.add_argument(
        "--order",
        metavar="COL",
        help="prognostic methods: the column ordering each unit's rows (numbers or "
        "timestamps; default --time, else time/timestamp/date/cycle)",
    )
    p.add_argument(
        "--window",
        type=_positive_int,
        metavar="N",
        help="prognostic methods: smooth each unit's path over N rows (moving mean) "
        "first; snapshot indicators are noisy",
    )
    p.add_argument("--top", type=int, default=20, help="rows in the summary")
    p.set_defaults(func=_cmd_rank)

    models = ["knn", "bagged_trees", "svm", "random_forest", "lda"]
    p = sub.add_parser("classify", help="train and evaluate a fault classifier")
    _add_input_options(p)
    p.add_argument("--model", default="knn", choices=models)
    p.add_argument(
        "--top-k", type=_positive_int, default=5, help="indicators kept by the selector"
    )
    p.add_argument("--selection", default="kruskal", choices=["kruskal", "anova", "pca"])
    p.add_argument(
        "--test-size",
        type=_fraction,
        default=0.25,
        help="share of the members held out for the test (0 to 1, default 0.25)",
    )
    p.add_argument(
        "--split",
        default="stratified",
        choices=["stratified", "time"],
        help="stratified: members drawn at random, each class on both sides "
        "(default); time: train on the earlier members, test on the later ones, "
        "ordered by --order",
    )
    p.add_argument(
        "--order",
        metavar="COL",
        help="--split time: the column ordering the members in time (numbers or "
        "timestamps; default --time of a --features table, else a condition named "
        "time/timestamp/date/cycle, else the order the members were given in)",
    )
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=_cmd_classify)

    p = sub.add_parser("sensors", help="compare sensors by accuracy and cost")
    _add_input_options(p)
    p.add_argument(
        "--sensor",
        action="append",
        metavar="NAME=SIG[,SIG]",
        help="a sensor and the signals it owns (repeat); default: one per signal",
    )
    p.add_argument("--costs", type=Path, help="TOML file of sensor costs")
    p.add_argument("--model", default="knn", choices=models)
    p.add_argument(
        "--top-k", type=_positive_int, default=5, help="indicators kept per sensor"
    )
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=_cmd_sensors)

    p = sub.add_parser("rul", help="train and evaluate a remaining-useful-life model")
    p.add_argument(
        "--dataset",
        default="cmapss-fd001",
        help="run-to-failure dataset: cmapss-fd001 (default, NASA C-MAPSS), "
        "pneumatic-leak (the twin's air-leak runs) or nasa-battery (Li-ion cells, "
        "leave-one-cell-out, degradation models); or give --train/--test",
    )
    p.add_argument(
        "--model",
        default="similarity",
        choices=[
            "similarity",
            "pairwise",
            "hash",
            "degradation",
            "linear-degradation",
            "wiener",
            "wiener-noisy",
            "gamma-process",
            "survival",
            "covariate",
            "boosting",
            "neural",
        ],
        help="RUL model (boosting: gradient-boosted trees on windowed sensors, the "
        "strong learned model; default similarity)",
    )
    p.add_argument(
        "--rul-cap",
        type=_rul_cap,
        default="convention",
        metavar="N|none",
        help="cap RUL targets, predictions and the true RULs of the headline scores at "
        "N (default: none for --train/--test tables; the named dataset's convention, "
        "125 cycles for cmapss-fd001, said in the output)",
    )
    p.add_argument(
        "--time-unit",
        metavar="UNIT",
        help="unit of the time column, shown on every score, axis and line, e.g. "
        "cycles, s, min, h (default: cycles for a cycle column, s for a time column "
        "or timestamps)",
    )
    p.add_argument(
        "--unit",
        metavar="COL",
        help="column telling the units apart in --train/--test/--history (default unit)",
    )
    p.add_argument(
        "--time",
        metavar="COL",
        help="time column of --train/--test/--history (default time, else cycle; "
        "timestamps become seconds)",
    )
    p.add_argument(
        "--wide",
        metavar="NAME",
        help="--train/--test/--history are wide tables: a time column (--time, else "
        "the first column) and one column per unit holding its indicator NAME (e.g. "
        "the IMS bearing files: a timestamp and one column per bearing)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the estimators' draws")
    p.add_argument(
        "--train",
        type=Path,
        help="your own run-to-failure units: a long table (CSV / Parquet) with unit, "
        "time or cycle and the sensor columns; without --test a quarter of the units "
        "is held out, each cut at 10-90 %% of its life",
    )
    p.add_argument(
        "--test",
        type=Path,
        help="test units' histories, with rul_true_final (each unit's true RUL after "
        "its last row); with --train",
    )
    p.add_argument("--features", nargs="+", help="input columns (default: all numeric)")
    p.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an estimator setting (repeat), e.g. k=5, level=0.8, threshold=1.0",
    )
    p.add_argument(
        "--dataset-option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="pneumatic-leak simulation setting (repeat): n_train, n_test, max_cycles, "
        "t_end, walk_shape",
    )
    p.add_argument(
        "--calibrate",
        action="store_true",
        help="rescale the model's intervals on held-out training units so that they "
        "hold their level (conformal; estimates unchanged)",
    )
    p.add_argument(
        "--trained",
        type=Path,
        metavar="MODEL",
        help="answer RULs with a trained model (DIR/model.pdmkit of an earlier run) "
        "instead of training; with --history",
    )
    p.add_argument(
        "--expect-sha256",
        metavar="HASH",
        help="with --trained: refuse the model file unless its SHA-256 is HASH (the "
        "model_sha256 its training run printed and wrote to rul.json)",
    )
    p.add_argument(
        "--history",
        type=Path,
        metavar="TABLE",
        help="units' histories so far (CSV / Parquet: unit, time or cycle, the model's "
        "columns); with --trained",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=Path("results/rul"),
        help="output folder: rul.json, predictions.parquet, report.html, model.pdmkit",
    )
    p.add_argument("--json", type=Path, help="also write the JSON summary here")
    p.set_defaults(func=_cmd_rul)

    p = sub.add_parser(
        "identify",
        help="identify a model (poles, resonances, damping) from an input/output record",
        description="Identify a linear (ar, arx, armax, oe, bj, n4sid), "
        "Hammerstein-Wiener (hw) or fractional-order model from a CSV/Parquet table "
        "or a .mat/.npz file.",
    )
    p.add_argument(
        "data", type=Path, metavar="DATA", help="CSV, Parquet, .mat or .npz recording"
    )
    p.add_argument(
        "--input", required=True, help="input column (.mat/.npz: variable, e.g. Force)"
    )
    p.add_argument(
        "--output",
        required=True,
        help="output column (.mat/.npz: variable; Acceleration2 = 2nd row of a 2-D one)",
    )
    p.add_argument(
        "--structure",
        default="arx",
        metavar="{" + ",".join(IDENTIFY_CHOICES) + "}",
        help="model structure (default arx); checked by the workflow, which also "
        "knows structures added to pdmkit.experiments._identify.IDENTIFY_STRUCTURES",
    )
    p.add_argument(
        "--order", default=None, help="4, or na=4,nb=3,nk=1 (default: by --criterion)"
    )
    p.add_argument("--criterion", default="aic", choices=["aic", "bic", "mdl"])
    p.add_argument("--fs", type=float, help="sampling rate (Hz) when there is no time")
    p.add_argument(
        "--band",
        metavar="F1,F2",
        help="band of interest in Hz: fit and modes focus on it (decimates "
        "automatically when it lies far below Nyquist)",
    )
    p.add_argument(
        "--decimate",
        type=int,
        metavar="N",
        help="decimate by N first (anti-aliased); 1 turns automatic decimation off",
    )
    p.add_argument("--out", type=Path, default=Path("results/identify"))
    p.add_argument("--json", type=Path)
    p.set_defaults(func=_cmd_identify)

    p = sub.add_parser(
        "mismatch",
        help="locate and explain where a model file and a recording differ",
        description="Fit MODEL_FILE to DATA, locate the residual, try the candidate "
        "physics and name the effect the model left out. MODEL_FILE is Python code, run "
        "with your rights: it can do anything you can (read, write and delete files, "
        "start programs). Trust it like code you would run. It is first imported and "
        "its rhs evaluated on DATA's first samples in a child process limited to "
        "--model-timeout seconds (a hang or an exit there is an error), then run in "
        "this process.",
    )
    p.add_argument(
        "model_file",
        type=Path,
        metavar="MODEL_FILE",
        help="model file (.py): Python code, run with your rights",
    )
    p.add_argument("data", type=Path, metavar="DATA", help="CSV or Parquet recording")
    p.add_argument(
        "--validation",
        type=Path,
        help="second recording for validation (default: the last third of DATA)",
    )
    p.add_argument(
        "--effects", help="comma-separated candidate effect ids to try (default: all)"
    )
    p.add_argument(
        "--model-timeout",
        type=float,
        default=30.0,
        metavar="SECONDS",
        help="time limit for importing MODEL_FILE and evaluating its rhs in the child "
        "check (default 30)",
    )
    p.add_argument(
        "--input-hold",
        default="auto",
        choices=["auto", "zoh", "foh"],
        help="the inputs between samples: zoh held (steps, a digital controller), foh "
        "straight lines (sampled continuous signals); auto (default) decides from the "
        "data: held when most samples repeat the one before",
    )
    p.add_argument(
        "--max-seconds",
        type=_positive_seconds,
        default=None,
        metavar="SECONDS",
        help="time budget: when it runs out the fits stop, the optional stages (pairs, "
        "data-driven terms) are skipped and the best verdict so far is reported, marked "
        "as such (default: no limit)",
    )
    p.add_argument("--out", type=Path, default=Path("results/mismatch"))
    p.add_argument("--json", type=Path)
    p.set_defaults(func=_cmd_mismatch)

    p = sub.add_parser("study", help="run one of the source studies end to end")
    p.add_argument("name", choices=sorted(STUDIES), help="the study (see below)")
    p.add_argument("--out", type=Path, help="output folder (default results/study/NAME)")
    p.add_argument("--json", type=Path, help="also write the summary JSON here")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated rig (0)")
    p.add_argument(
        "--quick", action="store_true", help="a smaller, faster run for a first look"
    )
    p.epilog = "studies: " + "; ".join(f"{k}: {v[2]}" for k, v in sorted(STUDIES.items()))
    p.set_defaults(func=_cmd_study)

    add_designer_parser(sub)

    p = sub.add_parser("demo", help="the whole workbench on the simulated pneumatic piston")
    p.add_argument("--out", type=Path, default=Path("results/demo"))
    p.add_argument("--json", type=Path)
    p.add_argument(
        "--members", type=int, default=None, help="recordings of the seed data set (480)"
    )
    p.add_argument(
        "--recording-s", type=float, default=10.0, help="seconds per recording (10)"
    )
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``pdmkit`` command; return its exit status."""
    args = build_parser().parse_args(argv)
    try:
        with collect_warnings():  # a run's JSON lists the warnings of the whole command
            return int(args.func(args) or 0)
    except (
        DataError,
        ModelError,
        FileNotFoundError,
        PermissionError,
        ConnectionError,
    ) as exc:
        _say("error: " + " ".join(line.strip() for line in str(exc).splitlines()))
        return 2
