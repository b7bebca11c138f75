"""A run's files in `--out` are consistent whenever it is killed, and runs never collide.

Consistent: ``features.parquet``, ``errors.parquet``, ``summary.json`` and
``report.html`` are all the files of one run (the SHA-256 of each in that run's
manifest, its run id in the JSON and the report, the JSON's ``n_members`` the table's
rows), and the table is the one an uninterrupted run writes.
"""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdmkit._outputs import OUTPUTS, OutputRun
from pdmkit.ensembles import Ensemble
from pdmkit.experiments._cli import main

ENV = {**os.environ, "PYTHONWARNINGS": "ignore"}


@pytest.fixture
def ensemble(tmp_path) -> Path:
    rng = np.random.default_rng(7)
    ens = Ensemble(
        {"x": rng.normal(size=(24, 4096)), "y": rng.normal(size=(24, 2048))},
        fs={"x": 2000.0, "y": 1000.0},
        conditions={"fault": np.array(["ok", "worn", "cracked"])[np.arange(24) % 3]},
    )
    return ens.to_parquet(tmp_path / "ens", members_per_file=5)


def _args(ensemble: Path, out: Path, *extra: str) -> list[str]:
    return ["features", "--ensemble", str(ensemble), "--out", str(out),
            "--batch-size", "4", *extra]  # fmt: skip


def _cli(ensemble: Path, out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "pdmkit", *_args(ensemble, out, *extra)]


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _user_files(out: Path) -> dict[str, str]:
    out.mkdir(parents=True, exist_ok=True)
    (out / "notes.txt").write_text("mine\n")
    (out / "sub").mkdir(exist_ok=True)
    (out / "sub" / "keep.csv").write_text("a,b\n1,2\n")
    return {name: _sha(out / name) for name in ("notes.txt", "sub/keep.csv")}


def _consistent(out: Path, user: dict[str, str]) -> pd.DataFrame:
    """Assert that OUT holds exactly one run's features files; return its table."""
    manifest = json.loads((out / ".pdmkit" / "run.json").read_text())
    assert manifest["command"] == "features"
    assert set(manifest["files"]) == set(OUTPUTS["features"])
    for name, info in manifest["files"].items():
        assert _sha(out / name) == info["sha256"], f"{name} is not of run {manifest}"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["run_id"] == manifest["run_id"]
    assert f'content="{manifest["run_id"]}"' in (out / "report.html").read_text()
    table = pd.read_parquet(out / "features.parquet")
    assert summary["n_members"] == len(table)
    assert summary["features"] == [c for c in table.columns if "/" in c]
    assert not list((out / ".pdmkit").glob("staging-*"))
    assert not list((out / ".pdmkit").glob("commit-*"))
    assert not [p for p in out.rglob("*.tmp")]
    assert {k: _sha(out / k) for k in user} == user
    return table


def _child(argv: list[str], log: str) -> None:
    """Run ``pdmkit argv`` in a forked process: the import is paid once, by the test."""
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    try:
        code = main(argv)
    except BaseException:  # a traceback is a failure the parent looks for
        import traceback

        traceback.print_exc()
        code = 99
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def _start(argv: list[str], log: Path) -> multiprocessing.Process:
    proc = _FORK.Process(target=_child, args=(argv, str(log)))
    proc.start()
    return proc


_FORK = multiprocessing.get_context("fork")


@pytest.mark.slow
def test_kill_at_random_moments_then_rerun_is_consistent(ensemble, tmp_path):
    # a whole `python -m pdmkit features` once, as a user runs it
    expected_out = tmp_path / "reference"
    subprocess.run(_cli(ensemble, expected_out), env=ENV, check=True, capture_output=True)
    expected = pd.read_parquet(expected_out / "features.parquet")

    # then killed (SIGKILL) at 20 moments drawn uniformly over a run's duration; the
    # runs are forked from this process, so the moments fall on the run's work rather
    # than on Python's start-up
    out = tmp_path / "out"
    user = _user_files(out)
    log = tmp_path / "child.log"
    assert main(_args(ensemble, out)) == 0  # warm: the forked runs import nothing more
    durations = []
    for _ in range(3):  # the duration of a whole (warm) run
        start = time.monotonic()
        proc = _start(_args(ensemble, out, "--fresh"), log)
        proc.join(60)
        assert proc.exitcode == 0, log.read_text()
        durations.append(time.monotonic() - start)
    duration = float(np.median(durations))
    rng = np.random.default_rng(20240611)
    killed = 0
    for moment in rng.uniform(0.0, duration, size=20):
        # --fresh: each killed run recomputes everything, so a kill may strike while
        # the store is cleared, a partition is written, or the results are committed
        proc = _start(_args(ensemble, out, "--fresh"), log)
        time.sleep(moment)
        proc.kill()
        proc.join(60)
        killed += proc.exitcode == -signal.SIGKILL
        assert proc.exitcode in (0, -signal.SIGKILL), log.read_text()
        # what any later run does first (under the lock): finish or drop what the
        # killed run left; OUT then holds one run's files, the killed run's or the
        # one before (the old table beside the new JSON would fail here)
        with OutputRun(out, "features") as run:
            run.open()
        pd.testing.assert_frame_equal(_consistent(out, user), expected, check_exact=True)
        assert main(_args(ensemble, out)) == 0  # the rerun
        table = _consistent(out, user)
        pd.testing.assert_frame_equal(table, expected, check_exact=True)
    assert killed >= 5, f"only {killed} of 20 runs were killed before they finished"


@pytest.mark.slow
def test_two_runs_on_one_folder_never_collide(ensemble, tmp_path):
    out = tmp_path / "out"
    user = _user_files(out)
    settings = (("--groups", "stats"), ("--groups", "stats", "spectral"))
    for _ in range(5):
        logs = [tmp_path / f"run-{i}.log" for i in range(2)]
        procs = [
            _start(_args(ensemble, out, *extra), log)
            for extra, log in zip(settings, logs, strict=True)
        ]
        for proc, log in zip(procs, logs, strict=True):
            proc.join(120)
            err = log.read_text()
            # both finish (the second waits for the first), or one is refused with
            # the documented one-line error naming the other's pid
            refused = "is in use by pdmkit features run, pid" in err
            assert proc.exitcode == 0 or (proc.exitcode == 2 and refused), err
            assert "Traceback" not in err
        table = _consistent(out, user)  # one of the two runs' files, all of them
        assert len(table) == 24 and table.notna().all().all()


def test_a_held_folder_is_refused_naming_the_holder(
    ensemble, tmp_path, monkeypatch, capsys
):
    import fcntl

    out = tmp_path / "out"
    user = _user_files(out)
    assert main(_args(ensemble, out)) == 0
    before = {p: _sha(p) for p in out.rglob("*") if p.is_file() and p.name != "lock"}
    (out / ".pdmkit").mkdir(exist_ok=True)
    with open(out / ".pdmkit" / "lock", "r+") as handle:  # another run holds OUT
        fcntl.flock(handle, fcntl.LOCK_EX)
        handle.seek(0)
        handle.truncate()
        handle.write(json.dumps({"pid": 4242, "command": "features", "started": "now"}))
        handle.flush()
        monkeypatch.setenv("PDMKIT_LOCK_WAIT", "0.3")
        assert main(_args(ensemble, out, "--groups", "stats")) == 2
        assert main(["classify", "--features", str(out / "features.parquet"),
                     "--label", "fault", "--out", str(out)]) == 2  # fmt: skip
    err = capsys.readouterr().err
    refusals = [line for line in err.splitlines() if line.startswith("pdmkit: error:")]
    assert len(refusals) == 2
    assert all("in use by pdmkit features run, pid 4242" in r for r in refusals)
    after = {p: _sha(p) for p in out.rglob("*") if p.is_file() and p.name != "lock"}
    assert after == before
    _consistent(out, user)


def test_leftovers_of_dead_runs_are_cleaned_by_the_next_run(ensemble, tmp_path):
    out = tmp_path / "out"
    user = _user_files(out)
    assert main(_args(ensemble, out)) == 0
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    leftovers = [
        out / ".pdmkit" / f"staging-20240101T000000Z-{dead}-abcdef" / "features.parquet",
        out / f".features.parquet.{dead}.k2j4h5g6.tmp",
        out / ".report.html.ab12cd34.tmp",  # an earlier pdmkit version's temporary
        out / ".pdmkit" / f".run.json.{dead}.zz99.tmp",
        out / "run" / "parts" / f".part-00003.{dead}.q1w2e3.tmp" / "meta.json",
        out / "run" / "parts" / f".part-00001.old-{dead}" / "meta.json",
    ]
    for path in leftovers:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("half-written")
    live = out / f".features.parquet.{os.getpid()}.live01.tmp"  # a live writer's
    live.write_text("being written")
    (out / ".notes.txt.swp").write_text("the user's editor")
    assert main(_args(ensemble, out)) == 0
    for path in leftovers:
        assert not path.exists(), path
    assert not (out / ".pdmkit" / f"staging-20240101T000000Z-{dead}-abcdef").exists()
    assert live.read_text() == "being written"
    assert (out / ".notes.txt.swp").read_text() == "the user's editor"
    live.unlink()
    _consistent(out, user)


class _Killed(BaseException):
    """Stands for a kill: nothing after it runs."""


def test_a_commit_cut_short_is_rolled_forward_by_the_next_run(
    ensemble, tmp_path, monkeypatch
):
    from pdmkit import _outputs

    out = tmp_path / "out"
    user = _user_files(out)
    assert main(_args(ensemble, out, "--groups", "stats")) == 0
    old = json.loads((out / ".pdmkit" / "run.json").read_text())

    def cut_short(out_dir, commit):  # the first file moved in, then the kill
        manifest = json.loads((commit / "manifest.json").read_text())
        first = next(iter(manifest["files"]))
        os.replace(commit / first, out_dir / first)
        raise _Killed

    monkeypatch.setattr(_outputs, "_roll_forward", cut_short)
    with pytest.raises(_Killed), pytest.warns(UserWarning, match="discarded the 6"):
        main(_args(ensemble, out, "--groups", "stats", "spectral"))
    monkeypatch.undo()
    (commit,) = (out / ".pdmkit").glob("commit-*")
    new = json.loads((commit / "manifest.json").read_text())
    # the window a kill leaves: the new table beside the old JSON and report
    assert _sha(out / "features.parquet") == new["files"]["features.parquet"]["sha256"]
    assert _sha(out / "summary.json") == old["files"]["summary.json"]["sha256"]

    # any later run on OUT (here another command) first finishes the cut commit, then
    # writes its own files (its summary.json and report.html replace the features run's)
    moved = []  # after each roll-forward: which of the cut run's files are in OUT
    real_roll = _outputs._roll_forward

    def watched(*args, **kwargs):
        result = real_roll(*args, **kwargs)
        moved.append({n: _sha(out / n) == new["files"][n]["sha256"] for n in new["files"]})
        return result

    monkeypatch.setattr(_outputs, "_roll_forward", watched)
    assert main(["classify", "--features", str(out / "features.parquet"), "--label",
                 "fault", "--top-k", "2", "--out", str(out)]) == 0  # fmt: skip
    monkeypatch.undo()
    assert moved and all(moved[0].values()), moved  # first: all of the cut run
    for name in ("features.parquet", "errors.parquet"):
        assert _sha(out / name) == new["files"][name]["sha256"], name
    summary = json.loads((out / "summary.json").read_text())
    assert "accuracy" in summary and summary["run_id"] != new["run_id"]
    assert not list((out / ".pdmkit").glob("commit-*"))
    assert {k: _sha(out / k) for k in user} == user


def test_a_failed_run_does_not_block_the_corrected_rerun(ensemble, tmp_path, capsys):
    out = tmp_path / "out"
    user = _user_files(out)
    # a bad option value: every member fails, nothing is produced (exit 2)
    assert main(_args(ensemble, out, "--option", "nperseg=-5")) == 2
    assert "nperseg must be an integer" in capsys.readouterr().err
    assert not (out / "features.parquet").exists()
    # corrected, without --fresh: the failed run's store is replaced, with a warning
    with pytest.warns(UserWarning, match="earlier failed run made with other settings"):
        assert main(_args(ensemble, out)) == 0
    _consistent(out, user)
    summary = json.loads((out / "summary.json").read_text())
    assert any("discarded the" in w for w in summary["warnings"])
    # a bad --option name is refused before anything is written: the rerun just works
    assert main(_args(ensemble, out, "--option", "nperseg_typo=3")) == 2
    assert main(_args(ensemble, out)) == 0
    _consistent(out, user)
