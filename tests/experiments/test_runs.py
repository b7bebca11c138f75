"""Resumable runs: a killed run restarts where it stopped and gives the same table."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdmkit.ensembles import Ensemble
from pdmkit.errors import DataError
from pdmkit.experiments._runs import RunDirectory, extract_features_run
from pdmkit.features import extract_ensemble


def _ensemble(n: int = 24, samples: int = 2048, seed: int = 0) -> Ensemble:
    rng = np.random.default_rng(seed)
    return Ensemble(
        {"x": rng.normal(size=(n, samples)), "y": rng.normal(size=(n, samples // 2))},
        fs={"x": 1000.0, "y": 500.0},
        conditions={"label": np.array(["a", "b", "c"])[np.arange(n) % 3]},
    )


def _stamps(run: Path) -> dict[str, tuple[int, int]]:
    out = {}
    for meta in (run / "parts").glob("*/meta.json"):
        st = meta.stat()
        out[meta.parent.name] = (st.st_mtime_ns, st.st_ino)
    return out


def test_run_equals_extract_ensemble_and_resumes(tmp_path):
    path = _ensemble().to_parquet(tmp_path / "ens", members_per_file=5)
    run = tmp_path / "run"
    table, errors = extract_features_run(path, run, batch_size=4)
    expected = extract_ensemble(path, batch_size=4)
    pd.testing.assert_frame_equal(table, expected, check_exact=True)
    assert errors.empty
    assert len(_stamps(run)) == 6  # 24 members / 4

    # lose two partitions (as a crash would): only those are computed again
    before = _stamps(run)
    for key in ("part-00001", "part-00004"):
        for f in (run / "parts" / key).iterdir():
            f.unlink()
        (run / "parts" / key).rmdir()
    again, _ = extract_features_run(path, run, batch_size=4)
    after = _stamps(run)
    pd.testing.assert_frame_equal(again, expected, check_exact=True)
    kept = set(before) - {"part-00001", "part-00004"}
    assert {k: after[k] for k in kept} == {k: before[k] for k in kept}
    assert after["part-00001"] != before["part-00001"]


def test_changed_config_or_input_is_refused(tmp_path):
    ens = _ensemble()
    path = ens.to_parquet(tmp_path / "ens")
    run = tmp_path / "run"
    extract_features_run(path, run, groups=("stats",), batch_size=8)
    with pytest.raises(DataError, match=r"config differs \(batch_size: 8 -> 6\).*--fresh"):
        extract_features_run(path, run, groups=("stats",), batch_size=6)
    # the input changed on disk: refused as well
    _ensemble(seed=1).to_parquet(path)
    with pytest.raises(DataError, match=r"inputs differs.*--fresh"):
        extract_features_run(path, run, groups=("stats",), batch_size=8)
    # fresh=True starts over with the new input
    table, _ = extract_features_run(path, run, groups=("stats",), batch_size=8, fresh=True)
    pd.testing.assert_frame_equal(
        table, extract_ensemble(path, groups=("stats",), batch_size=8), check_exact=True
    )


def test_a_folder_that_is_not_a_run_is_left_alone(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(DataError, match=r"not a pdmkit run directory.*notes\.txt"):
        RunDirectory(tmp_path, kind="x", config={}, inputs={})
    with pytest.raises(DataError, match="would delete"):
        RunDirectory(tmp_path, kind="x", config={}, inputs={}, fresh=True)
    assert (tmp_path / "notes.txt").read_text() == "mine"


@pytest.mark.slow
def test_sigkill_halfway_then_rerun_gives_the_same_table(tmp_path):
    rng = np.random.default_rng(3)
    n = 96
    ens = Ensemble(
        {"x": rng.normal(size=(n, 50_000)), "y": rng.normal(size=(n, 50_000))},
        fs=10_000.0,
        conditions={"k": np.arange(n) % 2},
    )
    path = ens.to_parquet(tmp_path / "ens", members_per_file=8)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "pdmkit", "features", "--ensemble", str(path)]
    cmd += ["--out", str(out), "--batch-size", "4", "--groups", "stats", "spectral"]
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    proc = subprocess.Popen(cmd, env=env, stderr=subprocess.DEVNULL)
    parts = out / "run" / "parts"
    deadline = time.monotonic() + 60
    while len(list(parts.glob("part-*/meta.json"))) < 5:
        assert proc.poll() is None, "the run finished before it could be killed"
        assert time.monotonic() < deadline, "the run made no progress"
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL
    done = _stamps(out / "run")
    assert 5 <= len(done) < 24, f"{len(done)} of 24 partitions done at the kill"
    assert not (out / "features.parquet").exists()

    rerun = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert rerun.returncode == 0, rerun.stderr
    after = _stamps(out / "run")
    assert len(after) == 24
    assert {k: after[k] for k in done} == done  # finished partitions were not redone
    assert not list(parts.glob(".*"))  # no half-written leftovers
    table = pd.read_parquet(out / "features.parquet")
    expected = extract_ensemble(path, batch_size=4)
    pd.testing.assert_frame_equal(table, expected, check_exact=True)
