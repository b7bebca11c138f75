"""The ``pdmkit`` console command.

``pdmkit --version`` answers from here at once; everything else goes to the full
command-line interface (:func:`pdmkit.experiments._cli.main`), whose import pulls in
scikit-learn, scipy and pandas (about a second). The command's Python warnings are
printed as ``pdmkit: warning: <message>`` lines, each distinct one once and its repeats
counted at the end (:func:`pdmkit.experiments._messages.cli_warnings`); calling
pdmkit's functions from Python keeps Python's own warnings.

Examples
--------
>>> from pdmkit._entry import main
>>> main(["--version"])
pdmkit 0.1.0
0
"""

from __future__ import annotations

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``pdmkit`` command with ``argv`` (default: the process's arguments).

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after ``pdmkit``.

    Returns
    -------
    int
        The exit status.
    """
    args = list(sys.argv[1:] if argv is None else argv)
    if args == ["--version"]:
        from pdmkit import __version__

        print(f"pdmkit {__version__}")
        return 0
    from pdmkit.experiments._cli import main as run_cli
    from pdmkit.experiments._messages import cli_warnings

    with cli_warnings():  # warnings as `pdmkit: warning:` lines, each once
        return run_cli(args)
