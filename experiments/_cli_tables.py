"""The feature-table commands: ``features``, ``rank``, ``classify``, ``sensors``.

Their options, and the one call each makes to its workflow (:func:`run_features`,
:func:`run_rank`, :func:`run_classify`, :func:`run_sensors` in
``_table_workflows.py``); the members come from a :class:`TableSource` built from the
input flags.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pdmkit.experiments._classify_run import run_classify, run_predict
from pdmkit.experiments._cli_common import (
    EXIT_SKIPPED,
    add_output_options,
    fraction,
    positive_int,
    say,
)
from pdmkit.experiments._sources import TableSource, add_member_options
from pdmkit.experiments._table_workflows import (
    run_features,
    run_rank,
    run_sensors,
)

__all__ = ["add_parsers"]

#: ``--model`` of classify and sensors
CLASSIFIERS = ["knn", "bagged_trees", "svm", "random_forest", "lda"]


def _cmd_features(args: argparse.Namespace) -> int:
    summary = run_features(
        TableSource.from_namespace(args),
        out_dir=args.out,
        json_path=args.json,
        batch_size=args.batch_size,
        workers=args.workers,
        scheduler=args.scheduler,
        fresh=args.fresh,
        strict=args.strict,
    )
    if summary["n_skipped"]:
        say(
            f"{summary['n_skipped']} member(s) skipped for bad input, e.g. "
            f"{summary['errors'][0]['error']}; see {summary['errors_path']} (exit "
            f"status {EXIT_SKIPPED}; --strict stops at the first)",
            always=True,
        )
        return EXIT_SKIPPED
    return 0


def _cmd_rank(args: argparse.Namespace) -> int:
    run_rank(
        TableSource.from_namespace(args),
        out_dir=args.out,
        json_path=args.json,
        method=args.method,
        unit=args.unit,
        order=args.order,
        window=args.window,
        top=args.top,
        stability_folds=args.stability_folds,
        group=args.group,
    )
    return 0


def _cmd_classify(args: argparse.Namespace) -> int:
    run_classify(
        TableSource.from_namespace(args),
        out_dir=args.out,
        json_path=args.json,
        model=args.model,
        top_k=args.top_k,
        selection=args.selection,
        test_size=args.test_size,
        split=args.split,
        order=args.order,
        group=args.group,
        gap=args.gap,
        test_where=args.test_where,
        test_table=args.test,
        seed=args.seed,
    )
    return 0


def _cmd_predict(args: argparse.Namespace) -> int:
    run_predict(
        args.model,
        TableSource(
            members=args.members,
            features=args.features,
            label_from_name=args.label_from_name,
            labels=args.labels,
            quiet=args.quiet,
        ),
        out_dir=args.out,
        json_path=args.json,
        group=args.group,
    )
    return 0


def _cmd_sensors(args: argparse.Namespace) -> int:
    run_sensors(
        TableSource.from_namespace(args),
        out_dir=args.out,
        json_path=args.json,
        sensors=args.sensor,
        costs=args.costs,
        model=args.model,
        top_k=args.top_k,
        seed=args.seed,
        group=args.group,
    )
    return 0


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``features``, ``rank``, ``classify`` and ``sensors``."""
    _add_features_parser(sub)
    _add_rank_parser(sub)
    _add_classify_parser(sub)
    _add_predict_parser(sub)
    _add_sensors_parser(sub)


def _add_features_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("features", help="extract condition indicators")
    add_input_options(p, features_ok=False)
    add_scale_options(p)
    p.set_defaults(func=_cmd_features)


def _add_rank_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("rank", help="rank condition indicators")
    add_input_options(p)
    p.add_argument(
        "--method",
        default="fisher",
        choices=[
            "fisher",
            "kruskal",
            "anova",
            "auc",
            "bhattacharyya",
            "monotonicity",
            "trendability",
            "prognosability",
        ],
        help="fisher (default; Fisher's discriminant ratio), kruskal, anova, auc "
        "(one-vs-rest ROC AUC), bhattacharyya: separate the --label classes; "
        "monotonicity, trendability, prognosability (Coble & Hines): track degradation "
        "over the run-to-failure rows of each --unit, ordered by --order/--time. The "
        "default was kruskal: its H, like the AUC of two classes, is the same for every "
        "indicator that separates the classes completely; fisher and bhattacharyya "
        "keep growing with the gap between them",
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
        type=positive_int,
        metavar="N",
        help="prognostic methods: smooth each unit's path over N rows (moving mean) "
        "first; snapshot indicators are noisy",
    )
    p.add_argument("--top", type=int, default=20, help="rows in the summary")
    p.add_argument(
        "--stability-folds",
        type=positive_int,
        metavar="N",
        help="class methods: also rank on the training rows of N cross-validation "
        "folds and report each indicator's mean rank, its spread and how often it is "
        "in the top 10, and the mean Spearman/Kendall correlation between the folds",
    )
    p.add_argument(
        "--group",
        metavar="COL",
        help="with --stability-folds: the column whose rows stay together in one fold "
        "(e.g. record, the recording that frames were cut from)",
    )
    p.set_defaults(func=_cmd_rank)


def _add_classify_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("classify", help="train and evaluate a fault classifier")
    add_input_options(p)
    p.add_argument(
        "--model", default="knn", choices=CLASSIFIERS, help="the classifier (default knn)"
    )
    p.add_argument(
        "--top-k", type=positive_int, default=5, help="indicators kept by the selector"
    )
    p.add_argument(
        "--selection",
        default="fisher",
        choices=["fisher", "kruskal", "anova", "bhattacharyya", "pca"],
        help="how the --top-k indicators are chosen (default fisher: the Fisher ratio "
        "keeps telling separated classes apart, where Kruskal-Wallis H saturates and "
        "picks among tied indicators by accident)",
    )
    p.add_argument(
        "--test-size",
        type=fraction,
        default=0.25,
        help="share of the members held out for the test (0 to 1, default 0.25)",
    )
    p.add_argument(
        "--split",
        default="auto",
        choices=["auto", "group", "random", "stratified", "time"],
        help="auto (default): whole recordings held out when members are frames of "
        "recordings (a source_member column) or --group is given, else random; group: "
        "hold out whole --group groups, class by class (a class recorded once is split "
        "in time blocks with a gap); random / stratified: members drawn at random, "
        "frames of one recording on both sides (says so); time: train on the earlier "
        "members, test on the later ones, ordered by --order",
    )
    p.add_argument(
        "--group",
        metavar="COL",
        help="the condition naming each member's recording, session or unit: its "
        "members stay on one side of every split (default source_member when framed)",
    )
    p.add_argument(
        "--gap",
        type=positive_int,
        default=1,
        help="members dropped between the training and test block of a class recorded "
        "once (default 1; at least the overlap of overlapping frames)",
    )
    test = p.add_mutually_exclusive_group()
    test.add_argument(
        "--test-where",
        metavar="EXPR",
        help="test on the members this expression selects, train on the others "
        '(pandas syntax on the condition columns, e.g. "size == 21")',
    )
    test.add_argument(
        "--test",
        type=Path,
        metavar="TABLE",
        help="a second feature table to test on (same indicators, matched by name); "
        "its accuracy is test_accuracy in the JSON",
    )
    p.add_argument(
        "--order",
        metavar="COL",
        help="--split time: the column ordering the members in time (numbers or "
        "timestamps; default --time of a --features table, else a condition named "
        "time/timestamp/date/cycle, else the order the members were given in)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the split and model (0)")
    p.set_defaults(func=_cmd_classify)


def _add_predict_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "predict", help="score new recordings with a classifier saved by classify"
    )
    p.add_argument(
        "--model",
        type=Path,
        required=True,
        metavar="FILE",
        help="model.pdmkit written by pdmkit classify or the designer (read safely: "
        "nothing in it runs)",
    )
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--members",
        nargs="+",
        metavar="FILE",
        help="recordings: the model's recipe computes its indicators from them "
        "(same signals, groups, options, rate and framing)",
    )
    source.add_argument(
        "--features", type=Path, help="a feature table (columns matched by name)"
    )
    p.add_argument(
        "--label-from-name",
        metavar="REGEX",
        help="conditions from the --members file names (kept beside the predictions)",
    )
    p.add_argument(
        "--labels", type=Path, metavar="TABLE", help="a table of the files' conditions"
    )
    p.add_argument(
        "--group",
        metavar="COL",
        help="the column naming each member's recording for the vote (default "
        "source_member when framed)",
    )
    add_output_options(p, "predictions")
    p.set_defaults(func=_cmd_predict)


def _add_sensors_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sensors", help="compare sensors by accuracy and cost")
    add_input_options(p)
    p.add_argument(
        "--sensor",
        action="append",
        metavar="NAME=SIG[,SIG]",
        help="a sensor and the signals it owns (repeat); default: one per signal",
    )
    p.add_argument("--costs", type=Path, help="TOML file of sensor costs")
    p.add_argument(
        "--model", default="knn", choices=CLASSIFIERS, help="the classifier (default knn)"
    )
    p.add_argument(
        "--top-k", type=positive_int, default=5, help="indicators kept per sensor"
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the split and model (0)")
    p.add_argument(
        "--group",
        metavar="COL",
        help="the condition naming each member's recording, session or unit: kept on "
        "one side of every fold (default source_member when framed)",
    )
    p.set_defaults(func=_cmd_sensors)


def add_input_options(parser: argparse.ArgumentParser, *, features_ok: bool = True) -> None:
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
        ".mat with a timetable or an fs variable, .npz with an fs variable; folders and "
        "glob patterns too)",
    )
    if features_ok:
        source.add_argument(
            "--features", type=Path, help="feature table (Parquet, CSV or text)"
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
    # --fs, --time, --label-from-name, --labels, --resample, --frame, --hop: shared
    # with `pdmkit designer`
    add_member_options(
        parser,
        time_help="the time column (seconds or timestamps) when it is not named time: "
        "of the --members tables, or of the --features table (rank, classify --split "
        "time)",
    )
    _add_bearing_and_output_options(parser)


def _add_bearing_and_output_options(parser: argparse.ArgumentParser) -> None:
    """The envelope group's bearing and shaft speed; --out, --json, --quiet."""
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
    add_output_options(parser, "results")


def add_scale_options(parser: argparse.ArgumentParser) -> None:
    cluster = parser.add_mutually_exclusive_group()
    cluster.add_argument(
        "--workers",
        type=positive_int,
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
        type=positive_int,
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
