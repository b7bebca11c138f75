"""The ``pdmkit`` console command's entry point: ``--version`` answers without the CLI."""

from __future__ import annotations

import subprocess
import sys

from pdmkit import __version__
from pdmkit._entry import main


def test_version_answers_without_importing_the_heavy_layers():
    # a fresh interpreter: nothing imported by other tests can hide an import
    code = (
        "import sys; from pdmkit._entry import main; status = main(['--version']); "
        "heavy = [m for m in ('sklearn', 'scipy', 'pandas', 'torch', "
        "'pdmkit.experiments') if m in sys.modules]; print(status, heavy)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.splitlines()
    assert out == [f"pdmkit {__version__}", "0 []"]


def test_everything_else_goes_to_the_full_cli(capsys):
    assert main(["datasets"]) == 0
    assert "cmapss-fd001" in capsys.readouterr().out
