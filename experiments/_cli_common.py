"""What every ``pdmkit`` command shares: messages, output folders, option types."""

from __future__ import annotations

import argparse
import json
import math
import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from pdmkit._outputs import OutputRun
from pdmkit.errors import DataError
from pdmkit.experiments._messages import finish, say

__all__ = [
    "EXIT_SKIPPED",
    "INPUT_FIELDS",
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


#: The flags (and :class:`~pdmkit.experiments.TableSource` fields) naming the files and
#: folders a command reads.
INPUT_FIELDS = (
    "members",
    "ensemble",
    "costs",
    "data",
    "model_file",
    "validation",
    "train",
    "test",
    "trained",
    "history",
    "features",
)


def input_paths(source: argparse.Namespace | Any) -> list:
    """The files and folders a command reads (never to be overwritten by its output).

    ``source`` is a command's parsed flags or a :class:`~pdmkit.experiments.TableSource`:
    the values of its :data:`INPUT_FIELDS`, lists of paths flattened.

    Examples
    --------
    >>> import argparse
    >>> input_paths(argparse.Namespace(members=["a.csv", "b.csv"], costs="costs.toml"))
    ['a.csv', 'b.csv', 'costs.toml']
    """
    paths = []
    for name in INPUT_FIELDS:
        value = getattr(source, name, None)
        if isinstance(value, str | os.PathLike):
            paths.append(value)
        elif isinstance(value, Iterable):
            paths += list(value)
        elif value is not None:
            paths.append(value)
    return paths


def output_run(args: argparse.Namespace, command: str) -> OutputRun:
    """The run that writes ``command``'s files into ``--out`` (checked before any work)."""
    return OutputRun(args.out, command, inputs=input_paths(args), json_path=args.json)


def add_output_options(parser: argparse.ArgumentParser, default: str) -> None:
    """Add ``--out DIR`` (default ``default``), ``--json PATH`` and ``--quiet``."""
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
    parser.add_argument(
        "--quiet",
        action="store_true",
        help="print nothing on success: no progress bars, no pdmkit: lines (warnings, "
        "one line each, and errors still show on stderr)",
    )


#: A key an untrusted options text may hold: a name of at most 64 characters.
_OPTION_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,63}$")


def parse_options(
    items: Sequence[str],
    flag: str = "--option",
    example: str = "ar_order=12",
    *,
    untrusted: bool = False,
) -> dict:
    """``["ar_order=12", "frf_input=Force"]`` -> ``{"ar_order": 12, "frf_input": "Force"}``.

    Values are read as JSON where they parse (numbers, lists, true/false, null),
    otherwise kept as text (a signal name). ``untrusted=True`` checks options from a
    file pdmkit did not write (a designer project): each key a name (letters, digits
    and ``_``, at most 64 characters), each value a finite number, text, true/false,
    null, or a list of at most 64 of them (or of pairs of them).

    Examples
    --------
    >>> parse_options(["ar_order=12", "bands=[[0,100]]", "frf_input=Force"])
    {'ar_order': 12, 'bands': [[0, 100]], 'frf_input': 'Force'}
    >>> parse_options(["x-1=2"], untrusted=True)
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: --option takes KEY=VALUE, e.g. ar_order=12; got 'x-1=2'
    """
    options = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key or (untrusted and not _OPTION_NAME.match(key)):
            raise DataError(f"{flag} takes KEY=VALUE, e.g. {example}; got {item!r}")
        options[key] = _checked_value(text) if untrusted else _json_or_text(text)
    return options


def _json_or_text(text: str):
    """``text`` read as JSON where it parses, else the text itself."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def _checked_value(text: str):
    """An untrusted option value: a finite number, text, true/false, null, a short list."""
    try:
        value = json.loads(text)
    except ValueError:
        return text
    ok = (int, float, str, bool, type(None))
    if isinstance(value, list):
        if len(value) > 64 or not all(
            isinstance(v, ok) or (isinstance(v, list) and all(isinstance(u, ok) for u in v))
            for v in value
        ):
            raise DataError(f"option value {text!r:.60}: a list of numbers or pairs only")
        return value
    if not isinstance(value, ok):
        raise DataError(f"option value {text!r:.60}: numbers, text, true/false or null")
    if isinstance(value, float) and not math.isfinite(value):
        raise DataError(f"option value {text!r:.60} is not finite")
    return value


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
