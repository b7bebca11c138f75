"""The ``pdmkit`` command line.

Every sub-command writes its results as data (Parquet / JSON) and a self-contained HTML
report into ``--out DIR``, beside whatever the folder already holds: only the command's
own files are replaced, all of one run at once (:mod:`pdmkit._outputs`);
``--json PATH`` writes the machine-readable summary anywhere but in pdmkit's own
``.pdmkit`` folders. Errors in the input, and usage errors (an unknown option, a missing
or bad argument), end the command with exit status 2 and one line on stderr that names
the problem; results already written are never half-overwritten.

This module parses and dispatches; each command's options and its one call to its
workflow live in one module: ``_cli_tables`` (features, rank, classify, sensors →
``_table_workflows``), ``_cli_rul`` (rul → ``_rul``), ``_cli_models`` (identify →
``_identify``, mismatch → ``_mismatch``); the demo, the studies and ``datasets`` here;
the designer in :mod:`pdmkit.experiments.designer`.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from pdmkit._outputs import collect_warnings
from pdmkit._progress import silenced
from pdmkit.errors import DataError, MissingExtraError, ModelError, did_you_mean
from pdmkit.experiments import _cli_models, _cli_monitor, _cli_rul, _cli_tables
from pdmkit.experiments._cli_common import add_output_options, say
from pdmkit.experiments._messages import say_error
from pdmkit.experiments.designer import add_parser as add_designer_parser
from pdmkit.experiments.studies import STUDIES, run_study

__all__ = ["build_parser", "main"]


def _cmd_datasets(args: argparse.Namespace) -> int:
    from pdmkit.ensembles import DATASETS
    from pdmkit.experiments._datasets import PROFILES

    print("Datasets (loaders in pdmkit.ensembles):")
    for name, description in DATASETS.items():
        flag = "  [classify/sensors]" if name in PROFILES else ""
        print(f"  {name:16s} {description}{flag}")
    return 0


def _cmd_study(args: argparse.Namespace) -> int:

    out = args.out if args.out is not None else Path("results/study") / args.name
    start = time.perf_counter()
    run_study(args.name, out, json_path=args.json, seed=args.seed, quick=args.quick)
    seconds = time.perf_counter() - start
    say(f"{args.name} finished in {seconds:.0f} s; see {out}/report.html")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from pdmkit.experiments._demo import run_demo

    start = time.perf_counter()
    run_demo(
        args.out,
        members=args.n_members,
        seed=args.seed,
        recording_s=args.recording_s,
        json_path=args.json,
    )
    say(f"demo finished in {time.perf_counter() - start:.0f} s; see {args.out}/report.html")
    return 0


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

    _cli_tables.add_parsers(sub)
    _cli_rul.add_parsers(sub)
    _cli_models.add_parsers(sub)
    _cli_monitor.add_parsers(sub)

    p = sub.add_parser("study", help="run one of the source studies end to end")
    p.add_argument("name", choices=sorted(STUDIES), help="the study (see below)")
    p.add_argument("--out", type=Path, help="output folder (default results/study/NAME)")
    p.add_argument("--json", type=Path, metavar="PATH", help="also write summary.json here")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated rig (0)")
    p.add_argument(
        "--quick", action="store_true", help="a smaller, faster run for a first look"
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="print nothing on success (warnings and errors still show)",
    )
    p.epilog = "studies: " + "; ".join(f"{k}: {v[2]}" for k, v in sorted(STUDIES.items()))
    p.set_defaults(func=_cmd_study)

    add_designer_parser(sub)

    p = sub.add_parser("demo", help="the whole workbench on the simulated pneumatic piston")
    add_output_options(p, "results/demo")
    p.add_argument(
        "--n-members",
        type=int,
        default=None,
        metavar="N",
        help="recordings of the seed data set to simulate (default 480)",
    )
    p.add_argument(
        "--recording-s", type=float, default=10.0, help="seconds per recording (10)"
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the simulation (0)")
    p.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``pdmkit`` command; return its exit status.

    ``--quiet`` silences progress bars and ``pdmkit:`` lines (:func:`silenced`); an
    error is one ``pdmkit: error:`` line naming flags (:func:`say_error`). Warnings
    stay Python's here: the console command (:func:`pdmkit._entry.main`) prints them
    as ``pdmkit: warning:`` lines.
    """
    args = build_parser().parse_args(argv)
    try:
        # a run's JSON lists the warnings of the whole command
        with silenced(getattr(args, "quiet", False)), collect_warnings():
            return int(args.func(args) or 0)
    except (
        DataError,
        ModelError,
        MissingExtraError,
        FileNotFoundError,
        PermissionError,
        ConnectionError,
    ) as exc:
        say_error(exc)
        return 2
