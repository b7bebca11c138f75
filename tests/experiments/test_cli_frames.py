"""``--frame``, ``--hop``, ``--resample`` and an ``fs`` column of ``--labels`` on the
command line and in the designer (issue 30: recordings as they come).

The frame counts are checked against ``floor((N - L) / H) + 1`` of each file's N
samples, the rates against what the files are.
"""

from __future__ import annotations

import json
import math
import shlex
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdmkit.experiments._cli import build_parser, main


def _recordings(folder: Path, rng, sizes: dict[str, int]) -> list[Path]:
    """.npz recordings without a rate: 'ok' noise, 'worn' noise with impacts."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, n in sizes.items():
        x = rng.normal(size=n)
        if "worn" in name:
            x[::97] += 12.0
        np.savez(folder / f"{name}.npz", vib=x)
        paths.append(folder / f"{name}.npz")
    return paths


def _features(tmp_path: Path, name: str, *args: str) -> pd.DataFrame:
    out = tmp_path / name
    assert main(["features", *args, "--groups", "stats", "--out", str(out)]) == 0
    return pd.read_parquet(out / "features.parquet")


def test_features_frame_the_member_files_and_keep_source_member(tmp_path, rng):
    sizes = {"a_ok": 10_000, "b_worn": 7_000, "c_ok": 2_048}
    files = [str(p) for p in _recordings(tmp_path / "m", rng, sizes)]
    table = _features(
        tmp_path, "o1", "--members", *files, "--fs", "1000", "--frame", "2048"
    )
    expected = {m: (n - 2048) // 2048 + 1 for m, n in sizes.items()}  # 4, 3, 1
    assert table.groupby("source_member").size().to_dict() == expected
    assert table.index.tolist()[:2] == ["a_ok/f0000", "a_ok/f0001"]
    assert table["frame"].tolist() == [0, 1, 2, 3, 0, 1, 2, 0]
    # with a hop, in seconds or samples: the same frames, the same indicators
    by_samples = _features(
        tmp_path,
        "o2",
        "--members",
        *files,
        "--fs",
        "1000",
        "--frame",
        "1024",
        "--hop",
        "512",
    )
    by_seconds = _features(
        tmp_path, "o3", "--members", *files, "--fs", "1000", "--frame", "1.024s", "--hop",
        "512ms",
    )  # fmt: skip
    expected = {m: (n - 1024) // 512 + 1 for m, n in sizes.items()}
    assert by_samples.groupby("source_member").size().to_dict() == expected
    pd.testing.assert_frame_equal(by_seconds, by_samples, check_exact=True)


def test_classify_holds_the_frames_of_one_recording_together(tmp_path, rng):
    files = _recordings(
        tmp_path / "m", rng, {f"r{k}_{s}": 8192 for k in range(4) for s in ("ok", "worn")}
    )
    summary = tmp_path / "c.json"
    name = ["--label-from-name", r"_([a-z]+)\.npz$", "--top-k", "2", "--groups", "stats"]
    out = ["--out", str(tmp_path / "out"), "--json", str(summary), "--quiet"]
    members = ["--members", *map(str, files), "--fs", "1000", "--frame", "1024"]
    code = main(["classify", *members, *name, *out])
    assert code == 0
    result = json.loads(summary.read_text())
    assert result["accuracy"] == pytest.approx(1.0)
    assert "source_member" in json.dumps(result)  # the split names what held frames apart


def test_files_at_two_rates_need_resample(tmp_path, rng, capsys):
    fast, slow = tmp_path / "fast.npz", tmp_path / "slow.npz"
    t = np.arange(48_000) / 48_000.0
    np.savez(fast, vib=np.sin(2 * np.pi * 1000.0 * t))
    np.savez(slow, vib=rng.normal(size=12_000))
    labels = tmp_path / "labels.csv"
    labels.write_text("file,label,fs\nfast.npz,ok,48000\nslow.npz,worn,12000\n")
    base = ["features", "--members", str(fast), str(slow), "--labels", str(labels)]
    assert main([*base, "--strict", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "fast.npz is sampled at 48000 Hz" in err and "slow.npz at 12000 Hz" in err
    assert "--resample HZ" in err
    table = _features(tmp_path, "o", *base[1:], "--resample", "12000", "--frame", "0.25s")
    assert table.groupby("source_member").size().to_dict() == {"fast": 4, "slow": 4}
    assert table["fs_original"].tolist() == [48000.0] * 4 + [12000.0] * 4
    assert (tmp_path / "o" / "features.parquet").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--frame", "0"], "--frame must be positive; got '0'"),
        (["--frame", "a lot"], "--frame must be a number of samples (2048) or a"),
        (["--hop", "512"], "--hop '512' needs --frame LENGTH"),
        (["--frame", "4096", "--strict"], "short.npz has 3000 samples (3 s at 1000 Hz), "
         "fewer than one frame of 4096 samples"),
    ],
)  # fmt: skip
def test_frame_mistakes_are_one_line_errors(tmp_path, rng, capsys, args, message):
    files = _recordings(tmp_path / "m", rng, {"long": 9000, "short": 3000})
    out = tmp_path / "out"
    members = ["--members", *map(str, files), "--fs", "1000"]
    code = main(["features", *members, *args, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = [line for line in err.splitlines() if "error:" in line]
    assert len(lines) == 1 and message in lines[0], err
    assert not (out / "features.parquet").exists()


def test_a_file_shorter_than_a_frame_is_skipped_and_reported(tmp_path, rng, capsys):
    files = _recordings(tmp_path / "m", rng, {"long": 9000, "short": 3000})
    out = tmp_path / "out"
    members = ["--members", *map(str, files), "--fs", "1000"]
    code = main(["features", *members, "--frame", "4096", "--out", str(out)])
    assert code == 3
    assert "short.npz has 3000 samples" in capsys.readouterr().err
    table = pd.read_parquet(out / "features.parquet")
    assert table["source_member"].tolist() == ["long", "long"]


@pytest.mark.parametrize("flag", [["--frame", "2048"], ["--resample", "12000"]])
def test_framing_a_dataset_or_feature_table_is_refused(tmp_path, capsys, flag):
    features = tmp_path / "f.csv"
    features.write_text("member,label,x/stats/Rms\na,ok,1\nb,worn,2\n")
    out = ["--out", str(tmp_path / "o")]
    code = main(["rank", "--features", str(features), *flag, "--label", "label", *out])
    err = capsys.readouterr().err
    assert code == 2
    assert f"{flag[0]} applies to --members files" in err
    assert "the --features source is read as it is" in err


def test_bad_resample_rate_is_refused_by_the_parser(capsys):
    with pytest.raises(SystemExit) as info:
        build_parser().parse_args(["features", "--members", "a.npz", "--resample", "0"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "argument --resample: expected a positive sampling rate in Hz" in err


def test_designer_reads_members_with_the_same_flags(tmp_path, rng):
    pytest.importorskip("starlette", reason="pdmkit[designer] is not installed")
    from pdmkit.experiments.designer._app import _session_from
    from pdmkit.experiments.designer._export import command_lines, python_script

    files = _recordings(tmp_path / "m", rng, {"a": 6000, "b_worn": 5000})
    labels = tmp_path / "labels.csv"
    labels.write_text("file,fault,fs\na.npz,ok,2000\nb_worn.npz,worn,2000\n")
    reading = ["--resample", "1000", "--frame", "0.5s", "--hop", "250", "--no-browser"]
    args = build_parser().parse_args(
        ["designer", "--members", *map(str, files), "--labels", str(labels), *reading]
    )
    assert (args.resample, args.frame, args.hop, args.fs) == (1000.0, "0.5s", "250", None)
    session = _session_from(args)  # no server: the members it would show
    source = session.source
    assert source.signals == {"vib": 1000.0}
    # 6000 and 5000 samples at 2 kHz are 3000 and 2500 at 1 kHz: frames of 500 every 250
    counts = {"a": (3000 - 500) // 250 + 1, "b_worn": (2500 - 500) // 250 + 1}
    assert source.conditions.groupby("source_member").size().to_dict() == counts
    assert source.label == "fault"
    session.run_now("features", {"signals": ["vib"], "groups": ["stats"]})
    # the exported command line reads the files the same way: the same table
    command = shlex.split(command_lines(session)["commands"][0])
    assert command[command.index("--frame") + 1] == "0.5s"
    assert main([*command[1:-2], "--out", str(tmp_path / "cli"), "--quiet"]) == 0
    cli = pd.read_parquet(tmp_path / "cli" / "features.parquet")
    columns = [c for c in cli.columns if "/" in c]
    np.testing.assert_array_equal(cli[columns], session.table[columns])
    assert "resample=1000.0, frame='0.5s', hop='250'" in python_script(session)


def test_designer_refuses_member_flags_on_a_dataset(capsys):
    pytest.importorskip("starlette", reason="pdmkit[designer] is not installed")
    from pdmkit.errors import DataError
    from pdmkit.experiments.designer._app import _session_from

    args = build_parser().parse_args(["designer", "--dataset", "cwru", "--frame", "2048"])
    with pytest.raises(DataError, match="--frame applies to --members files"):
        _session_from(args)


@pytest.mark.real_data
def test_cwru_records_at_their_own_rates_in_frames(require_data, tmp_path, capsys):
    """The 48 kHz normal record and the 12 kHz fault records, framed at 12 kHz."""
    folder = require_data("cwru_bearing")
    files = sorted(folder.glob("*.npz"))
    assert len(files) == 5
    labels = tmp_path / "labels.csv"
    pd.DataFrame(
        {
            "file": [p.name for p in files],
            "label": [p.name.split(".")[0].split("_")[1] for p in files],
            "fs": [48000 if "Normal" in p.name else 12000 for p in files],
        }
    ).to_csv(labels, index=False)
    base = ["--members", *map(str, files), "--labels", str(labels), "--signals", "DE"]
    # without --resample: the two rates are named, nothing is read at one of them
    assert main(["features", *base, "--strict", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "1797_Normal.npz is sampled at 48000 Hz" in err and "at 12000 Hz" in err
    table = _features(tmp_path, "o", *base, "--resample", "12000", "--frame", "2048")
    counts = table.groupby("source_member").size().to_dict()
    expected = {}
    for p in files:
        n = np.load(p)["DE"].size
        if "Normal" in p.name:
            assert n == 243_938
            n = math.ceil(n / 4)  # resample_poly 1/4: 60985 samples at 12 kHz
        expected[p.name.split(".")[0]] = (n - 2048) // 2048 + 1
    assert counts == expected
    assert expected["1797_Normal"] == 29
    assert all(v == 59 for k, v in expected.items() if k != "1797_Normal")
    normal = table[table["source_member"] == "1797_Normal"]
    assert set(normal["fs_original"]) == {48000.0} and set(normal["label"]) == {"Normal"}
