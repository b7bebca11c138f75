"""What every ``pdmkit`` command shares: messages, output folders, option types."""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from pathlib import Path

from pdmkit._outputs import OutputRun
from pdmkit.errors import DataError
from pdmkit.experiments._messages import finish, say

__all__ = [
    "EXIT_SKIPPED",
    "add_output_options",
    "finish",
    "fraction",
    "input_paths",
    "number_type",
    "output_run",
    "parse_options",
    "positive_int",
    "positive_seconds",
    "progress_flag",
    "say",
]


def input_paths(args: argparse.Namespace) -> list:
    """The files and folders a command reads (never to be overwritten by its output)."""
    names = ["members", "ensemble", "costs", "data", "model_file", "validation"]
    names += ["train", "test", "trained", "history", "features"]
    paths = []
    for name in names:
        value = getattr(args, name, None)
        if isinstance(value, list | tuple):
            paths += list(value)
        elif value is not None:
            paths.append(value)
    return paths


def output_run(args: argparse.Namespace, command: str) -> OutputRun:
    """The run that writes ``command``'s files into ``--out`` (checked before any work)."""
    return OutputRun(args.out, command, inputs=input_paths(args), json_path=args.json)


def add_output_options(parser: argparse.ArgumentParser, default: str) -> None:
    """Add ``--out DIR`` (default ``default``) and ``--json PATH``, as every command has."""
    parser.add_argument(
        "--out",
        type=Path,
        default=Path(default),
        metavar="DIR",
        help=f"output folder: summary.json, report.html and the command's files (default "
        f"{default}); nothing else in it is touched",
    )
    parser.add_argument(
        "--json", type=Path, metavar="PATH", help="also write summary.json here"
    )


def parse_options(
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


def progress_flag(args: argparse.Namespace) -> bool | None:
    """Progress bars: off with --quiet, else on a terminal only (None)."""
    return False if getattr(args, "quiet", False) else None


#: Exit status of a command that finished but left members out (bad input).
EXIT_SKIPPED = 3


def number_type(convert, ok, what: str):
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


fraction = number_type(float, lambda v: 0 < v < 1, "a number in (0, 1)")


positive_int = number_type(int, lambda v: v >= 1, "a positive integer")


positive_seconds = number_type(
    float, lambda v: v > 0 and math.isfinite(v), "a positive number of seconds"
)
