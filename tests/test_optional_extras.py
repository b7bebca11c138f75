"""A core install (no extras) runs the everyday commands; an extra's feature says which.

torch (``pdmkit[neural]``), Dask (``pdmkit[dask]``) and numba (``pdmkit[fast]``) are
extras (pyproject.toml). One fresh interpreter, in which all three are made unimportable
exactly as if they were not installed (every import finder answers "not found" for
them), runs ``pdmkit features``, ``rank``, ``classify``, ``sensors`` and a similarity
``rul`` through the console command's own entry point, then asks for the neural RUL
model and a Dask cluster: each must fail with one ``pdmkit: error:`` line naming the
extra to install.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pandas as pd
import pytest

#: runs in the child before anything else: torch, dask, distributed and numba are not found
_BLOCK = """
import sys

BLOCKED = {"torch", "dask", "distributed", "numba", "llvmlite"}
assert not BLOCKED & set(sys.modules), "imported before the blocker"


class Hide:
    def __init__(self, inner):
        self.inner = inner

    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED:
            return None
        find = getattr(self.inner, "find_spec", None)
        return None if find is None else find(name, path, target)

    def __getattr__(self, attr):
        return getattr(self.inner, attr)


sys.meta_path[:] = [Hide(f) for f in sys.meta_path]
"""

_RUN = """
import contextlib, importlib.util, io, json, sys

import numpy as np, pandas as pd

from pdmkit._entry import main

out = {"specs": [importlib.util.find_spec(m) is None for m in sorted(BLOCKED)]}
for name, argv in json.loads(sys.argv[1]).items():
    with contextlib.redirect_stderr(io.StringIO()) as err:
        code = main(argv)
    out[name] = {"code": code, "stderr": err.getvalue()}

from pdmkit.rul import NeuralRULModel

table = pd.DataFrame({"unit": np.repeat([1, 2], 20), "time": np.tile(np.arange(20), 2),
                      "x": np.r_[np.arange(20) / 20, np.arange(20) / 15]})
try:
    NeuralRULModel(window=5, epochs=1, n_folds=2).fit(table)
except ImportError as exc:
    from pdmkit.errors import MissingExtraError, PdmkitError
    out["api"] = [type(exc).__name__, str(exc), isinstance(exc, PdmkitError)]
out["loaded"] = sorted(m for m in sys.modules if m.partition(".")[0] in BLOCKED)
print(json.dumps(out))
"""


def _toy_inputs(folder, rng):
    """Two classes of recordings (a 50 Hz tone, 1x and 3x) and run-to-failure units."""
    members = folder / "members"
    members.mkdir()
    t = np.arange(1024) / 1024.0
    for label, amp in (("ok", 1.0), ("bad", 3.0)):
        for i in range(10):
            acc = amp * np.sin(2 * np.pi * 50 * t) + rng.normal(0, 0.3, t.size)
            pd.DataFrame({"time": t, "acc": acc}).to_csv(
                members / f"{i}_{label}.csv", index=False
            )
    units = []
    for u in range(8):
        life = int(rng.integers(40, 80))
        c = np.arange(life)
        units.append(
            pd.DataFrame(
                {
                    "unit": u,
                    "cycle": c,
                    "s1": c / life + rng.normal(0, 0.02, life),
                    "s2": (c / life) ** 2 + rng.normal(0, 0.02, life),
                }
            )
        )
    pd.concat(units).to_csv(folder / "train.csv", index=False)
    return members, folder / "train.csv"


@pytest.fixture(scope="module")
def core_run(tmp_path_factory):
    """The child's answers: {command: {code, stderr}}, the API error, what it loaded."""
    folder = tmp_path_factory.mktemp("core")
    members, train = _toy_inputs(folder, np.random.default_rng(0))
    feats = str(folder / "feat" / "features.parquet")
    name_rx = r"^\d+_([a-z]+)"
    commands = {
        "features": ["features", "--members", str(members), "--label-from-name", name_rx],
        "rank": ["rank", "--features", feats, "--label", "label"],
        "classify": ["classify", "--features", feats, "--label", "label"],
        "sensors": ["sensors", "--features", feats, "--label", "label"],
        "rul": ["rul", "--train", str(train), "--model", "similarity", "--option", "k=3"],
        "neural": ["rul", "--train", str(train), "--model", "neural"],
        "workers": ["features", "--members", str(members), "--workers", "2"],
    }
    commands = {
        k: [*v, "--out", str(folder / ("feat" if k == "features" else k)), "--quiet"]
        for k, v in commands.items()
    }
    code = textwrap.dedent(_BLOCK) + textwrap.dedent(_RUN)
    done = subprocess.run(
        [sys.executable, "-c", code, json.dumps(commands)],
        capture_output=True,
        text=True,
        timeout=240,
        cwd=folder,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1]), folder


def test_the_blocker_hides_torch_and_dask(core_run):
    """The child really ran without them: nothing found, nothing loaded."""
    out, _ = core_run
    assert out["specs"] == [True] * 5
    assert out["loaded"] == []


@pytest.mark.parametrize("command", ["features", "rank", "classify", "sensors", "rul"])
def test_core_commands_run_without_torch_or_dask(core_run, command):
    out, folder = core_run
    assert out[command]["code"] == 0, out[command]["stderr"]
    assert "pdmkit: error:" not in out[command]["stderr"]
    out_dir = folder / ("feat" if command == "features" else command)
    summary = json.loads((out_dir / "summary.json").read_text())
    if command == "features":
        table = pd.read_parquet(out_dir / "features.parquet")
        assert len(table) == 20 and sorted(set(table["label"])) == ["bad", "ok"]
    if command == "classify":
        assert summary["accuracy"] > 0.9  # a 1x against a 3x tone
    if command == "rul":
        assert np.isfinite(summary["rmse"])


@pytest.mark.parametrize(
    ("command", "message"),
    [
        ("neural", "the neural RUL model needs torch: pip install 'pdmkit[neural]'"),
        ("workers", "needs dask[distributed]: pip install 'pdmkit[dask]'"),
    ],
)
def test_an_extras_feature_is_one_line_naming_the_extra(core_run, command, message):
    out, _ = core_run
    assert out[command]["code"] == 2
    lines = out[command]["stderr"].strip().splitlines()
    assert lines[-1].startswith("pdmkit: error: ") and message in lines[-1]
    assert "Traceback" not in out[command]["stderr"]


def test_the_python_api_raises_missing_extra_error(core_run):
    """From Python: an ImportError (and a PdmkitError) whose message names the extra."""
    out, _ = core_run
    kind, message, is_pdmkit_error = out["api"]
    assert kind == "MissingExtraError" and is_pdmkit_error
    assert message == "the neural RUL model needs torch: pip install 'pdmkit[neural]'"
