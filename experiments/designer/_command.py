"""The ``pdmkit designer`` command: its options and the start of the web app."""

from __future__ import annotations

import argparse
from pathlib import Path

from pdmkit._optional import require
from pdmkit.experiments._sources import add_member_options

__all__ = ["add_parser"]


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register the ``designer`` command with the ``pdmkit`` sub-command parsers.

    Examples
    --------
    >>> import argparse
    >>> sub = argparse.ArgumentParser(prog="pdmkit").add_subparsers(dest="command")
    >>> designer = add_parser(sub)
    >>> args = designer.parse_args(["--dataset", "cwru"])
    >>> args.dataset, args.host, args.port
    ('cwru', '127.0.0.1', 0)

    The ``--members`` files read as ``pdmkit features`` reads them:

    >>> args = designer.parse_args(
    ...     ["--members", "a.npz", "b.npz", "--labels", "labels.csv", "--resample",
    ...      "12000", "--frame", "0.1s", "--hop", "600"])
    >>> args.resample, args.frame, args.hop, str(args.labels)
    (12000.0, '0.1s', '600', 'labels.csv')

    A monitoring history, alone or beside the members:

    >>> designer.parse_args(["--history", "fleet.sqlite"]).history
    'fleet.sqlite'
    """
    p = sub.add_parser("designer", help="the interactive feature designer in the browser")
    source = p.add_mutually_exclusive_group()
    source.add_argument("--ensemble", type=Path, help="an on-disk ensemble folder")
    source.add_argument("--members", type=Path, nargs="+", help="recording files")
    source.add_argument("--dataset", help="a named dataset (see `pdmkit datasets`)")
    source.add_argument("--features", type=Path, help="a feature table to start from")
    # how --members files are read: --fs, --time, --label-from-name, --labels,
    # --resample, --frame, --hop (the flags of pdmkit features / classify)
    add_member_options(p)
    p.add_argument(
        "--project",
        type=Path,
        help="a saved designer project (JSON): re-open it where it was (its members "
        "unless one of the options above names others)",
    )
    p.add_argument(
        "--history",
        metavar="PATH|URL",
        help="a monitoring history (pdmkit monitor score --db): the History page shows "
        "its alarms and each unit's health over time, read-only; alone or beside the "
        "members",
    )
    p.add_argument("--host", default="127.0.0.1", help="address to bind (127.0.0.1)")
    p.add_argument("--port", type=int, default=0, help="port (0: a free one)")
    p.add_argument(
        "--no-browser", action="store_true", help="print the URL, do not open a browser"
    )
    p.set_defaults(func=_cmd_designer)
    return p


def _cmd_designer(args: argparse.Namespace) -> int:
    for package in ("starlette", "uvicorn", "plotly"):
        require(package, what="pdmkit designer")
    from pdmkit.experiments.designer._app import serve

    return serve(args)
