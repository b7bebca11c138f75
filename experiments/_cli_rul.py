"""The ``rul`` command: train and score a remaining-useful-life model, or answer one."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pandas as pd

from pdmkit._output_folder import check_output_folder
from pdmkit.errors import DataError
from pdmkit.experiments._cli_common import (
    add_output_options,
    input_paths,
    parse_options,
    say,
)
from pdmkit.experiments._report import _readable_float

__all__ = ["add_parsers"]


def _cmd_rul(args: argparse.Namespace) -> int:
    from pdmkit.experiments._rul import predict_rul, run_rul
    from pdmkit.experiments._rul_checks import cap_text

    if (args.trained is None) != (args.history is None):
        raise DataError("--trained MODEL and --history TABLE go together")
    if args.expect_sha256 is not None and args.trained is None:
        raise DataError("--expect-sha256 checks the file of --trained MODEL; give both")
    _check_modes(args)
    if args.trained is not None:
        answer = predict_rul(
            args.trained,
            args.history,
            json_path=args.json,
            expect_sha256=args.expect_sha256,
            unit=args.unit,
            time=args.time,
            time_unit=args.time_unit,
            out_dir=args.out,
        )
        for row in answer["units"]:
            print(row["text"])
        if args.out is not None:
            paths = answer["paths"]
            say(f"wrote {paths['predictions']}, {paths['json']} and {paths['report']}")
        return 0
    out = args.out if args.out is not None else Path(_DEFAULT_OUT)
    inputs = [*input_paths(args), args.test_rul]
    # before reading anything: --out must not overwrite --train / --test
    check_output_folder(out, "rul", inputs=inputs, json_path=args.json)
    dataset, time_unit = _rul_dataset(args)
    summary = run_rul(
        dataset,
        args.model,
        out_dir=out,
        json_path=args.json,
        seed=args.seed,
        rul_cap=args.rul_cap,
        features=args.columns,
        options=parse_options(args.option, example="k=5"),
        dataset_options=parse_options(
            args.dataset_option, "--dataset-option", "walk_shape=16"
        )
        or None,
        calibrate=args.calibrate,
        time_unit=time_unit,
        cv=args.cv,
    )
    u = summary.get("time_unit", "")
    capped = cap_text(summary.get("rul_cap"), u, summary.get("rul_cap_source", ""))
    n_warn = len(summary.get("warnings", []))
    cv = summary.get("cv")
    say(
        (f"cross-validated by unit ({cv['n_folds']} folds), " if cv else "")
        + f"{summary['model']}: RMSE {summary['rmse']:.2f} {u}, MAE {summary['mae']:.2f} "
        f"{u}, PHM08 score {_readable_float(summary['phm08_score'])}, "
        f"{100 * summary['level']:g} % interval coverage {summary['coverage']:.2f} on "
        f"{summary['n_units']} units; {capped}; time unit {u}"
        + (f"; {n_warn} warning(s), listed in summary.json" if n_warn else "")
        + f"; see {out}/report.html; trained model {summary['model_file']} "
        f"(sha256 {summary['model_sha256']}: keep it to check the file later with "
        "--expect-sha256)"
    )
    return 0


_DEFAULT_OUT = "results/rul"


def _check_modes(args: argparse.Namespace) -> None:
    """The flags of one mode together: answer, train and test, or cross-validate."""
    if args.test is not None and args.train is None:
        raise DataError("--test needs --train (the training units)")
    if args.test_rul is not None and args.test is None:
        raise DataError(
            "--test-rul FILE gives the true RULs of the --test units; give --train and "
            "--test with it"
        )
    if args.cv is not None and (args.train is None or args.test is not None):
        raise DataError(
            "--cv cross-validates the units of --train (one table, no --test); "
            "give --train TABLE without --test (nasa-battery is always "
            "leave-one-cell-out)"
        )
    if args.trained is not None and (args.train is not None or args.cv is not None):
        raise DataError("--trained answers with a trained model; drop --train / --cv")
    if args.train is None and args.trained is None and (args.unit or args.time):
        raise DataError("--unit and --time name columns of --train/--test/--history")


def _rul_dataset(args: argparse.Namespace):
    """What ``run_rul`` trains and scores on, and the time unit.

    A named dataset, a (train, test) pair (the test's true RULs from --test-rul, or
    drawn by a random cut of a quarter of the units), or one table to cross-validate.
    """
    from pdmkit.experiments._rul import split_run_to_failure
    from pdmkit.experiments._rul_tables import with_true_rul

    if args.train is None:
        return args.dataset, args.time_unit
    train, guessed = _rul_table(args, args.train)
    time_unit = args.time_unit or guessed
    if args.cv is not None:
        return train, time_unit
    if args.test is not None:
        test = _rul_table(args, args.test)[0]
        if args.test_rul is not None:
            test = with_true_rul(test, args.test_rul)
            say(
                f"{args.test_rul}: true RULs of the {test['unit'].nunique()} test units "
                "(the RUL after each unit's last row)"
            )
        return (train, test), time_unit
    dataset = split_run_to_failure(train, seed=args.seed)  # a quarter held out, cut
    say(
        f"{args.train}: {dataset[1]['unit'].nunique()} of {train['unit'].nunique()} "
        "units held out as test histories, each cut at 10-90 % of its life"
    )
    return dataset, time_unit


def _cv_choice(text: str) -> str | int:
    """``--cv units`` or ``--cv K`` (K >= 2)."""
    value = text.strip().lower()
    if value in ("units", "unit", "loo"):
        return "units"
    if value.isdigit() and int(value) >= 2:
        return int(value)
    raise argparse.ArgumentTypeError(
        f"expected 'units' (leave one unit out) or a number of folds >= 2, got {text!r}"
    )


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
        say(f"{path}: time column {name!r} holds timestamps: seconds since {origin}")
        guessed = "s"
    else:
        words = [w for w in re.split(r"[^a-z]+", str(name).lower()) if w]
        guessed = next((_RUL_TIME_UNITS[w] for w in words if w in _RUL_TIME_UNITS), "s")
        if args.time_unit is None and args.time is not None and path == args.train:
            say(
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
    say(
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


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``rul``."""
    p = sub.add_parser("rul", help="train and evaluate a remaining-useful-life model")
    _add_model_options(p)
    _add_table_options(p)
    # --out: results/rul when training; with --trained, files only where asked
    p.set_defaults(func=_cmd_rul, out=None)


def _add_model_options(p: argparse.ArgumentParser) -> None:
    """The data set, the model, its cap, the time unit and the key columns."""
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


def _add_table_options(p: argparse.ArgumentParser) -> None:
    """Your own tables, estimator settings, a trained model, the outputs."""
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
        "its last row) or --test-rul; with --train",
    )
    p.add_argument(
        "--test-rul",
        type=Path,
        metavar="FILE",
        help="true RULs of the --test units: one value per line, the RUL after each "
        "unit's last row, in unit order (C-MAPSS's RUL_FD001.txt), or two columns "
        "unit and RUL; the test units are scored against them",
    )
    p.add_argument(
        "--cv",
        type=_cv_choice,
        metavar="units|K",
        help="cross-validate --train by unit instead of holding out a test part: "
        "units = leave one unit out, K = K folds of units; each unit is followed "
        "through its life by a model trained without it, scored over its last half",
    )
    p.add_argument(
        "--columns",
        nargs="+",
        metavar="COL",
        help="the model's input columns (default: all numeric ones)",
    )
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
        "instead of training; with --history; with --out DIR also writes "
        "DIR/predictions.csv, summary.json and report.html",
    )
    p.add_argument(
        "--expect-sha256",
        metavar="HASH",
        help="with --trained: refuse the model file unless its SHA-256 is HASH (the "
        "model_sha256 its training run printed and wrote to summary.json)",
    )
    p.add_argument(
        "--history",
        type=Path,
        metavar="TABLE",
        help="units' histories so far (CSV / Parquet: unit, time or cycle, the model's "
        "columns); with --trained",
    )
    add_output_options(p, _DEFAULT_OUT)
