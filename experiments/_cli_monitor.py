"""``pdmkit monitor fit | score | watch``: health baselines and each asset's history."""

from __future__ import annotations

import argparse
from pathlib import Path

from pdmkit.experiments._cli_common import add_output_options, fraction, positive_int
from pdmkit.experiments._messages import say
from pdmkit.experiments._monitor_db import db_target

__all__ = ["add_parsers"]


def _cmd_fit(args: argparse.Namespace) -> int:
    from pdmkit.experiments._monitor import run_monitor_fit

    run_monitor_fit(
        args.features,
        out_dir=args.out,
        unit=args.unit,
        time=args.time,
        healthy_first=args.healthy_first,
        healthy_where=args.healthy_where,
        method=args.method,
        false_alarm_rate=args.false_alarms,
        persistence=args.persistence,
        json_path=args.json,
    )
    return 0


def _cmd_score(args: argparse.Namespace) -> int:
    from pdmkit.experiments._monitor import run_monitor_score

    run_monitor_score(
        args.model,
        args.features,
        db=args.db,
        out_dir=args.out,
        unit=args.unit,
        time=args.time,
        json_path=args.json,
        rul_model=args.rul,
    )
    return 0


def _cmd_watch(args: argparse.Namespace) -> int:
    from pdmkit.experiments._monitor import watch_folder

    watch_folder(
        args.model,
        args.folder,
        db=args.db,
        unit=args.unit,
        time=args.time,
        interval=args.interval,
        once=args.once,
        pattern=args.pattern,
        rul_model=args.rul,
    )
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from pdmkit.experiments._monitor_rul import export_history

    n = export_history(args.db, args.csv)
    say(f"{n} rows of {args.db} written to {args.csv} (unit, time, score, health_index)")
    return 0


def _unit_time(p: argparse.ArgumentParser) -> None:
    p.add_argument("--unit", metavar="COL", help="the column naming each asset")
    p.add_argument(
        "--time",
        metavar="COL",
        required=True,
        help="the time column (numbers or timestamps)",
    )


def _db_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--db",
        type=db_target,
        required=True,
        metavar="PATH|URL",
        help="the history: an SQLite file, or a database URL such as "
        "postgresql+psycopg://user@host/db (SQLAlchemy; pip install 'pdmkit[db]')",
    )


def _rul_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--rul",
        type=Path,
        metavar="MODEL",
        help="an RUL model (model.pdmkit of pdmkit rul, trained on health histories: "
        "unit, time, score, health_index): each touched unit's RUL is kept in the history",
    )


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``monitor`` and its sub-commands."""
    monitor = sub.add_parser("monitor", help="health baselines, alarms, asset histories")
    steps = monitor.add_subparsers(
        dest="step", required=True, metavar="STEP", help="fit, score, watch or export"
    )
    p = steps.add_parser("fit", help="fit a health baseline on healthy rows")
    p.add_argument("--features", type=Path, required=True, help="feature table")
    _unit_time(p)
    healthy = p.add_mutually_exclusive_group(required=True)
    healthy.add_argument(
        "--healthy-first",
        type=fraction,
        metavar="FRACTION",
        help="the first FRACTION of each unit's time span is healthy (e.g. 0.3)",
    )
    healthy.add_argument(
        "--healthy-where", metavar="EXPR", help="a pandas expression marking healthy rows"
    )
    p.add_argument(
        "--method",
        default="pca",
        choices=["pca", "pca_t2", "pca_q", "mahalanobis", "isolation_forest", "symbolic"],
        help="the health model (default pca: T2 and Q together)",
    )
    p.add_argument(
        "--false-alarms",
        default="0.01",
        metavar="RATE",
        help="target false-alarm rate of a healthy unit: per row (0.01, the default) or "
        "per time (1/30d; units s, min, h, d, w; needs timestamps in --time)",
    )
    p.add_argument(
        "--persistence",
        type=positive_int,
        default=3,
        help="consecutive rows above the threshold that raise the alarm (default 3)",
    )
    add_output_options(p, "monitor")
    p.set_defaults(func=_cmd_fit)

    p = steps.add_parser("score", help="score a feature table into the history")
    p.add_argument("--model", type=Path, required=True, help="model.pdmkit of monitor fit")
    p.add_argument("--features", type=Path, required=True, help="feature table")
    _db_option(p)
    _unit_time(p)
    _rul_option(p)
    add_output_options(p, "monitor_score")
    p.set_defaults(func=_cmd_score)

    p = steps.add_parser("watch", help="score every new table landing in a folder")
    p.add_argument("folder", type=Path, help="the folder to watch")
    p.add_argument("--model", type=Path, required=True, help="model.pdmkit of monitor fit")
    _db_option(p)
    _unit_time(p)
    p.add_argument(
        "--interval", type=float, default=10.0, help="seconds between passes (default 10)"
    )
    p.add_argument("--pattern", default="*.csv", help="files to take (default *.csv)")
    p.add_argument(
        "--once", action="store_true", help="one pass over the folder, then stop"
    )
    _rul_option(p)
    p.set_defaults(func=_cmd_watch)

    p = steps.add_parser(
        "export", help="the history as a table (unit, time, score, health_index)"
    )
    _db_option(p)
    p.add_argument(
        "--csv", type=Path, required=True, help="the CSV to write (must not exist)"
    )
    p.set_defaults(func=_cmd_export)
