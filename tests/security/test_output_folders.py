"""`--out` folders belong to the user: every command writes beside what is there.

Each command runs on an output folder that already holds the user's files (its own
input among them, a file named like nothing pdmkit writes, a hidden file, a sub-folder)
and stale copies of the command's own files; afterwards the user's files are
byte-identical, the command's files are the new run's (their SHA-256 in the run's
manifest), and nothing else was added but ``.pdmkit/``. Outputs that would destroy
input are refused with one line and exit status 2.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdmkit._outputs import MAIN_JSON, OUTPUTS
from pdmkit.experiments._cli import main

PRIVATE = {".pdmkit", "run"}  # pdmkit's own folders inside OUT


# --------------------------------------------------------------------------- inputs
def _recording(path: Path, n: int = 1500) -> Path:
    rng = np.random.default_rng(0)
    u = rng.normal(size=n)
    y = np.zeros(n)
    for k in range(2, n):  # a resonance: y[k] = 1.6 y[k-1] - 0.9 y[k-2] + 0.1 u[k-1]
        y[k] = 1.6 * y[k - 1] - 0.9 * y[k - 2] + 0.1 * u[k - 1]
    pd.DataFrame({"time": np.arange(n) / 100.0, "force": u, "acc": y}).to_csv(
        path, index=False
    )
    return path


def _feature_table(path: Path) -> Path:
    rng = np.random.default_rng(1)
    fault = np.repeat(["ok", "worn"], 30)
    pd.DataFrame(
        {
            "acc/stats/RMS": rng.normal(size=60) + 3.0 * (fault == "worn"),
            "acc/stats/Kurtosis": rng.normal(size=60) + 2.0 * (fault == "worn"),
            "mic/stats/RMS": rng.normal(size=60),
            "fault": fault,
        }
    ).to_parquet(path)
    return path


def _units(path: Path, n: int = 12) -> Path:
    rng = np.random.default_rng(2)
    rows = []
    for unit in range(1, n + 1):
        life = int(rng.integers(40, 70))
        t = np.arange(1, life + 1)
        rows.append(
            pd.DataFrame(
                {
                    "unit": unit,
                    "cycle": t,
                    "s1": (t / life) ** 2 + rng.normal(0, 0.03, life),
                    "s2": 1 - (t / life) ** 3 + rng.normal(0, 0.03, life),
                }
            )
        )
    table = pd.concat(rows, ignore_index=True)
    if path.suffix == ".parquet":
        table.to_parquet(path)
    else:
        table.to_csv(path, index=False)
    return path


def _members(folder: Path, n: int = 6) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(3)
    for i in range(n):
        t = np.arange(512) / 1000.0
        x = np.sin(2 * np.pi * (50 + 10 * i) * t) + 0.1 * rng.normal(size=t.size)
        pd.DataFrame({"time": t, "x": x}).to_csv(folder / f"m{i}.csv", index=False)
    return folder


def _command(command: str, inputs: Path, out: Path) -> list[str]:
    """A small run of ``command`` whose input files live in ``inputs``."""
    inputs.mkdir(parents=True, exist_ok=True)
    if command == "identify":
        data = _recording(inputs / "rig.csv")
        args = ["identify", data, "--input", "force", "--output", "acc"]
        args += ["--order", "na=2,nb=1"]
    elif command == "mismatch":
        from pdmkit.models.mismatch._cases import generate_concealed_case

        paths = generate_concealed_case("none", 0.2, seed=1, n_samples=300).write(inputs)
        args = ["mismatch", paths["model"], paths["data"], "--effects", "sensor_offset"]
    elif command == "rul":
        args = ["rul", "--train", _units(inputs / "units.csv"), "--model", "similarity"]
    elif command == "features":
        args = ["features", "--members", _members(inputs / "recordings")]
        args += ["--groups", "stats"]
    elif command in ("classify", "sensors", "rank"):
        args = [command, "--features", _feature_table(inputs / "table.parquet")]
        args += ["--label", "fault"]
        if command == "classify":
            args += ["--top-k", "2"]
    elif command == "demo":
        args = ["demo", "--n-members", "80", "--recording-s", "2.2"]
    else:  # pragma: no cover
        raise AssertionError(command)
    return [str(a) for a in [*args, "--out", out]]


# --------------------------------------------------------------------------- helpers
def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _snapshot(folder: Path, skip=()) -> dict[str, str]:
    """Relative path -> SHA-256 of every file below ``folder`` but ``skip``."""
    out = {}
    for path in sorted(folder.rglob("*")):
        rel = path.relative_to(folder).as_posix()
        if rel.split("/")[0] in PRIVATE or rel in skip or not path.is_file():
            continue
        out[rel] = _sha(path)
    return out


def _user_files(out: Path) -> None:
    (out / "notes.txt").write_text("my notes\n")
    (out / "my-results.json").write_text('{"mine": true}\n')
    (out / ".hidden").write_bytes(b"\x00\x01")
    (out / "sub" / "deeper").mkdir(parents=True)
    (out / "sub" / "deeper" / "data.bin").write_bytes(bytes(range(256)))
    (out / "sub" / "report.html").write_text("not pdmkit's: in a sub-folder\n")


def _assert_committed(out: Path, command: str) -> dict:
    """The run's files are all there, as its manifest lists them; nothing left over."""
    manifest = json.loads((out / ".pdmkit" / "run.json").read_text())
    assert manifest["command"] == command
    assert set(manifest["files"]) == set(OUTPUTS[command])
    for name, info in manifest["files"].items():
        assert _sha(out / name) == info["sha256"], name
    summary = json.loads((out / MAIN_JSON[command]).read_text())
    assert summary["run_id"] == manifest["run_id"]
    assert isinstance(summary["warnings"], list)
    html = (out / "report.html").read_text()
    assert f'<meta name="pdmkit-run" content="{manifest["run_id"]}">' in html
    leftovers = [
        p
        for p in out.rglob("*")
        if p.name.endswith(".tmp") or p.name.startswith(("staging-", "commit-"))
    ]
    assert leftovers == []
    return manifest


COMMANDS = ["identify", "mismatch", "rul", "features", "classify", "sensors", "rank"]


# --------------------------------------------------------------------------- tests
# the demo's case runs in tests/experiments/test_demo.py (one demo run for both)
@pytest.mark.parametrize("command", COMMANDS)
def test_user_files_stay_and_pdmkit_files_are_replaced(command, tmp_path):
    out = tmp_path / "out"
    argv = _command(command, out, out)  # the inputs live in OUT too
    argv += ["--json", str(tmp_path / "summary-copy.json")]
    _user_files(out)
    for name in OUTPUTS[command]:  # what an earlier run of the command left
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_text("stale\n")
    own = set(OUTPUTS[command])
    before = _snapshot(out, skip=own)
    assert main(argv) == 0
    assert _snapshot(out, skip=own) == before  # the user's files, byte for byte
    first = _assert_committed(out, command)
    for name in own:
        assert (out / name).read_bytes() != b"stale\n", name
    copy = tmp_path / "summary-copy.json"
    assert copy.read_bytes() == (out / MAIN_JSON[command]).read_bytes()
    added = {p.name for p in out.iterdir()} - {Path(r).parts[0] for r in before}
    assert added <= {Path(n).parts[0] for n in own} | PRIVATE
    assert main(argv) == 0  # a rerun replaces pdmkit's files, and only those
    assert _snapshot(out, skip=own) == before
    second = _assert_committed(out, command)
    assert second["run_id"] != first["run_id"]


@pytest.mark.parametrize("command", [*COMMANDS, "demo"])
def test_out_naming_a_file_is_refused(command, tmp_path, capsys):
    argv = _command(command, tmp_path / "in", tmp_path / "out")
    target = tmp_path / "results.txt"
    target.write_text("mine\n")
    argv[argv.index("--out") + 1] = str(target)
    before = _snapshot(tmp_path)
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pdmkit: error: ")
    assert "is an existing file" in lines[0] and str(target) in lines[0]
    assert _snapshot(tmp_path) == before


@pytest.mark.parametrize("command", [*COMMANDS, "demo"])
def test_json_naming_a_folder_is_refused(command, tmp_path, capsys):
    argv = _command(command, tmp_path / "in", tmp_path / "out")
    folder = tmp_path / "summaries"
    folder.mkdir()
    (folder / "old.json").write_text("{}\n")
    before = _snapshot(tmp_path)
    assert main([*argv, "--json", str(folder)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "is a folder" in lines[0] and str(folder) in lines[0]
    assert _snapshot(tmp_path) == before
    assert not (tmp_path / "out").exists()


def test_identify_into_the_working_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _recording(tmp_path / "rig.csv")
    (tmp_path / "notes.txt").write_text("mine\n")
    before = _snapshot(tmp_path)
    argv = ["identify", "rig.csv", "--input", "force", "--output", "acc", "--out", "."]
    assert main([*argv, "--order", "na=2,nb=1"]) == 0
    assert _snapshot(tmp_path, skip=OUTPUTS["identify"]) == before
    _assert_committed(tmp_path, "identify")


def _refused(argv, tmp_path, capsys, match: str) -> None:
    before = _snapshot(tmp_path)
    assert main([str(a) for a in argv]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pdmkit: error: "), lines
    assert match in lines[0], lines[0]
    assert _snapshot(tmp_path) == before  # nothing written, nothing deleted


def test_an_output_that_would_overwrite_an_input_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    over = "would overwrite the input"
    # identify / mismatch whose recording sits where the report or summary goes
    data = _recording(out / "report.html")
    _refused(
        ["identify", data, "--input", "force", "--output", "acc", "--out", out],
        tmp_path,
        capsys,
        over,
    )
    from pdmkit.models.mismatch._cases import generate_concealed_case

    paths = generate_concealed_case("none", 0.2, seed=1, n_samples=300).write(tmp_path)
    paths["data"].rename(out / "summary.json")
    _refused(
        ["mismatch", paths["model"], out / "summary.json", "--out", out],
        tmp_path,
        capsys,
        over,
    )
    # rul --train OUT/predictions.parquet, rank --features OUT/ranking.parquet
    train = _units(out / "predictions.parquet")
    _refused(["rul", "--train", train, "--out", out], tmp_path, capsys, over)
    table = _feature_table(out / "ranking.parquet")
    _refused(
        ["rank", "--features", table, "--label", "fault", "--out", out],
        tmp_path,
        capsys,
        over,
    )
    # a member file where features.parquet goes; the members' folder as --out
    members = _members(tmp_path / "recordings")
    (members / "m0.csv").rename(out / "features.parquet")
    _refused(
        ["features", "--members", out / "features.parquet", "--out", out],
        tmp_path,
        capsys,
        over,
    )
    _refused(
        ["features", "--members", members, "--out", members],
        tmp_path,
        capsys,
        "inside the input folder",
    )
    # --json naming the data file, or another of the run's files
    rig = _recording(tmp_path / "rig.csv")
    base = ["identify", rig, "--input", "force", "--output", "acc", "--out", out]
    _refused([*base, "--json", rig], tmp_path, capsys, "is the input")
    _refused([*base, "--json", out / "report.html"], tmp_path, capsys, "this run writes")


def test_rul_answer_json_must_not_overwrite_its_history(tmp_path, capsys):
    from pdmkit import save_model
    from pdmkit.rul import HealthIndicator, LinearDegradationModel, RULPipeline

    train = pd.read_csv(_units(tmp_path / "units.csv"))
    model = save_model(
        RULPipeline(HealthIndicator(["s1", "s2"]), LinearDegradationModel()).fit(train),
        tmp_path / "model.pdmkit",
    )
    history = tmp_path / "history.csv"
    train[train["unit"] == 1].iloc[:20].to_csv(history, index=False)
    base = ["rul", "--trained", model, "--history", history]
    _refused([*base, "--json", history], tmp_path, capsys, "is the input")
    _refused([*base, "--json", tmp_path], tmp_path, capsys, "is a folder")
    assert main([str(a) for a in [*base, "--json", tmp_path / "answer.json"]]) == 0
    answer = json.loads((tmp_path / "answer.json").read_text())
    assert answer["units"][0]["unit"] == 1 and answer["warnings"] == []


def test_warnings_of_the_run_land_in_its_summary(tmp_path, monkeypatch):
    from pdmkit.experiments import _table_workflows

    real = _table_workflows.extraction_input

    def noisy(*args, **kwargs):  # a warning raised twice while the run works
        for _ in range(2):
            warnings.warn("a warning of this run\nsecond line", RuntimeWarning, 1)
        return real(*args, **kwargs)

    monkeypatch.setattr(_table_workflows, "extraction_input", noisy)
    out = tmp_path / "out"
    with pytest.warns(RuntimeWarning, match="a warning of this run"):
        assert main(_command("features", tmp_path / "in", out)) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["warnings"] == ["RuntimeWarning: a warning of this run"]
    manifest = json.loads((out / ".pdmkit" / "run.json").read_text())
    assert manifest["warnings"] == summary["warnings"]


def test_features_run_store_keeps_what_it_did_not_write(tmp_path, capsys):
    """Red-team finding: a changed rerun emptied OUT/run/parts wholesale (a user's
    folder there included), and followed OUT/run when it was a link elsewhere."""
    members = _members(tmp_path / "in")
    out = tmp_path / "out"
    base = ["features", "--members", str(members), "--out", str(out)]
    assert main([*base, "--groups", "stats"]) == 0
    mine = out / "run" / "parts" / "mine"
    mine.mkdir()
    (mine / "x.txt").write_text("notes")
    assert main([*base, "--groups", "spectral"]) == 0  # other settings: parts replaced
    assert (mine / "x.txt").read_text() == "notes"
    # a link in place of the run store is refused; what it points to stays intact
    elsewhere = tmp_path / "elsewhere"
    (elsewhere / "parts" / "keep").mkdir(parents=True)
    (elsewhere / "parts" / "keep" / "x.txt").write_text("keep")
    linked = tmp_path / "out2"
    linked.mkdir()
    (linked / "run").symlink_to(elsewhere, target_is_directory=True)
    capsys.readouterr()
    code = main(["features", "--members", str(members), "--out", str(linked), "--fresh"])
    assert code == 2
    assert "symbolic link" in capsys.readouterr().err.strip().splitlines()[-1]
    assert (elsewhere / "parts" / "keep" / "x.txt").read_text() == "keep"
