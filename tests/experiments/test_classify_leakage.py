"""Classifiers judged on splits that cannot leak, and deployed by name.

The reference for what a leak does: frames cut from one recording share that
recording's fingerprint (mounting, load, sensor gain), so a random split of frames
scores a classifier that has learnt the fingerprints, not the fault (Hendriks et al.,
"Towards better benchmarking using the CWRU bearing fault dataset", MSSP 2022). The
tables below are built so that the fingerprint is all there is to learn.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError
from pdmkit.experiments import classify
from pdmkit.experiments._cli import main


def _framed(rng, n_rec=6, n_frames=20, fault_effect=0.0):
    """Frames of recordings: class A and B, each recording its own offset."""
    rows = []
    for cls in ("A", "B"):
        for r in range(n_rec):
            fingerprint = rng.normal(0, 3, size=4)
            shift = fault_effect * (cls == "B")
            for f in range(n_frames):
                x = fingerprint + rng.normal(0, 0.2, size=4)
                x[0] += shift
                rows.append(
                    {
                        **{f"s/stats/F{i}": v for i, v in enumerate(x)},
                        "fault": cls,
                        "source_member": f"{cls}{r}",
                        "frame": f,
                    }
                )
    table = pd.DataFrame(rows)
    table.index = table.source_member + "#" + table.frame.astype(str)
    return table


def test_random_split_of_frames_scores_fingerprints_the_grouped_split_does_not(rng):
    table = _framed(rng)  # the class is in no feature: chance is 0.5
    leaky = classify(table, "fault", model="knn", split="random", top_k=4)
    honest = classify(table, "fault", model="knn", top_k=4)
    assert leaky.accuracy > 0.95  # the recordings' fingerprints, memorised
    assert leaky.split_info["groups_on_both_sides"] > 0
    assert leaky.notes[0].startswith("random split of members that share")
    assert honest.split == "group" and honest.split_info["groups_on_both_sides"] == 0
    assert honest.accuracy < 0.8
    # every held-out recording is whole: none of its frames trained the model
    train = set(table.source_member.drop(honest.test_members))
    assert not train & set(table.source_member[honest.test_members])
    assert set(honest.group_scores()["group"]) == set(
        table.source_member[honest.test_members]
    )
    # the cross-validation folds are grouped too: no better than chance on average
    assert honest.cv_accuracy < 0.8


def test_grouped_split_keeps_a_real_effect(rng):
    table = _framed(rng, fault_effect=30.0)
    res = classify(table, "fault", model="lda", selection=None)
    assert res.split == "group" and res.accuracy == 1.0


def test_a_class_recorded_once_is_split_in_time_with_a_gap(rng):
    table = _framed(rng, n_rec=3, fault_effect=30.0)
    table = table[(table.fault == "A") | (table.source_member == "B0")]
    res = classify(table, "fault", selection=None, model="lda", gap=2, test_size=0.25)
    assert res.split_info["time_blocks"] == ["B"] and res.split_info["gap"] == 2
    frames = table.loc[res.test_members]
    b_test = frames[frames.fault == "B"]["frame"]
    trained = table.loc[res.train_members]
    b_train = trained[trained.fault == "B"]["frame"]
    assert b_test.min() - b_train.max() == 3  # two frames dropped between
    assert any("single recording" in n for n in res.notes)


def test_test_where_and_a_test_table_hold_out_what_the_user_names(rng):
    table = _framed(rng, fault_effect=30.0)
    res = classify(table, "fault", selection=None, model="lda", test_where="frame >= 15")
    assert res.split == "where" and res.n_test == 2 * 6 * 5
    assert (table.loc[res.test_members, "frame"] >= 15).all()
    other = _framed(np.random.default_rng(9), fault_effect=30.0)
    res = classify(table, "fault", selection=None, model="lda", test=other)
    assert res.split == "table" and res.n_test == len(other) and res.accuracy > 0.9
    with pytest.raises(DataError, match="lacks feature columns"):
        classify(table, "fault", test=other.drop(columns="s/stats/F0"))
    with pytest.raises(DataError, match="selects 0 of"):
        classify(table, "fault", test_where="frame > 100")


def test_cli_classify_saves_a_model_that_predict_scores_by_name(tmp_path, rng):
    table = _framed(rng, fault_effect=30.0)
    table.to_csv(tmp_path / "train.csv", index_label="member")
    out = tmp_path / "run"
    args = ["classify", "--features", str(tmp_path / "train.csv"), "--label", "fault"]
    assert main([*args, "--top-k", "2", "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["split"]["kind"] == "group" and summary["split"]["by"] == "source_member"
    assert summary["groups"] and (out / "model.pdmkit").is_file()
    reference = classify(table, "fault", top_k=2)
    assert summary["accuracy"] == reference.accuracy
    # new recordings, columns in another order: the same predictions as in training
    new = table.drop(columns="fault")[table.columns[::-1].drop("fault")]
    new.to_csv(tmp_path / "new.csv", index_label="member")
    pred = tmp_path / "pred"
    code = main(
        [
            "predict",
            "--model",
            str(out / "model.pdmkit"),
            "--features",
            str(tmp_path / "new.csv"),
            "--out",
            str(pred),
            "--quiet",
        ]
    )
    assert code == 0
    got = pd.read_csv(pred / "predictions.csv", index_col="member")
    expected = reference.pipeline.predict(table[reference.input_features].to_numpy())
    assert (got.loc[table.index, "predicted"].to_numpy() == expected).all()
    votes = pd.read_csv(pred / "recordings.csv")
    assert len(votes) == 12 and set(votes.predicted) == {"A", "B"}
    # a missing indicator column is a one-line error naming it
    new.drop(columns="s/stats/F1").to_csv(tmp_path / "bad.csv", index_label="member")
    bad = ["predict", "--model", str(out / "model.pdmkit"), "--features"]
    assert main([*bad, str(tmp_path / "bad.csv"), "--out", str(tmp_path / "p2")]) == 2


def test_cli_random_split_and_a_test_table(tmp_path, rng, capsys):
    table = _framed(rng)
    table.to_csv(tmp_path / "t.csv", index_label="member")
    other = _framed(np.random.default_rng(4))
    other.to_csv(tmp_path / "o.csv", index_label="member")
    base = ["classify", "--features", str(tmp_path / "t.csv"), "--label", "fault"]
    assert main([*base, "--split", "random", "--json", str(tmp_path / "r.json")]) == 0
    random_split = json.loads((tmp_path / "r.json").read_text())["split"]
    assert (
        random_split["kind"] == "random" and "seen in training" in random_split["measures"]
    )
    assert "random split of members that share" in capsys.readouterr().err
    code = main(
        [*base, "--test", str(tmp_path / "o.csv"), "--json", str(tmp_path / "t.json")]
    )
    assert code == 0
    summary = json.loads((tmp_path / "t.json").read_text())
    assert summary["split"]["kind"] == "table" and summary["test_accuracy"] < 0.8


CWRU_LABELS = """file,label,size,fs
1797_Normal.npz,normal,0,48000
1797_B_7_DE12.npz,ball,7,12000
1797_IR_7_DE12.npz,inner,7,12000
1797_IR_21_DE12.npz,inner,21,12000
1797_OR@6_7_DE12.npz,outer,7,12000
"""


def test_cwru_raw_files_grouped_transfer_and_predict(tmp_path, require_data, capsys):
    """The issue's check on the real files, each at its own rate: the default split
    keeps a recording's frames on one side (time blocks where a class was recorded
    once); trained on the 0.007 in faults, the IR_021 frames are inner-race faults
    (Hendriks et al. 2022 on why a random split says nothing here); the saved model
    scores new files as the training run scored them."""
    folder = require_data("cwru_bearing")
    (tmp_path / "labels.csv").write_text(CWRU_LABELS)
    files = sorted(str(p) for p in folder.glob("*.npz"))
    common = ["--members", *files, "--labels", str(tmp_path / "labels.csv")]
    common += ["--resample", "12000", "--frame", "2048", "--signals", "DE"]
    common += ["--bearing", "6205", "--shaft-hz", "29.95", "--quiet"]
    out = tmp_path / "grouped"
    assert main(["classify", *common, "--out", str(out)]) == 0
    grouped = json.loads((out / "summary.json").read_text())
    assert grouped["split"]["kind"] == "group"
    assert grouped["split"]["time_blocks"] == ["ball", "normal", "outer"]
    held_whole = [g["group"] for g in grouped["groups"] if g["members"] == 59]
    assert held_whole and held_whole[0].startswith("1797_IR_")  # inner: 2 recordings
    out = tmp_path / "transfer"
    assert main(["classify", *common, "--test-where", "size == 21", "--out", str(out)]) == 0
    transfer = json.loads((out / "summary.json").read_text())
    assert transfer["split"]["groups_on_both_sides"] == 0 and transfer["n_test"] == 59
    assert transfer["recall"]["inner"] >= 0.9  # measured: 59 of 59
    # the saved model on the IR_021 file alone: the same calls as the held-out run
    ir21 = [f for f in files if "IR_21" in f]
    (tmp_path / "new.csv").write_text("file,fs\n1797_IR_21_DE12.npz,12000\n")
    pred = tmp_path / "pred"
    args = ["predict", "--model", str(out / "model.pdmkit"), "--members", *ir21]
    assert main([*args, "--labels", str(tmp_path / "new.csv"), "--out", str(pred)]) == 0
    vote = pd.read_csv(pred / "recordings.csv")
    assert vote["predicted"].tolist() == ["inner"] and vote["members"].tolist() == [59]
    assert vote["agreement"].iloc[0] == transfer["recall"]["inner"]
    # a 48 kHz file: the model's recipe resamples it to the 12 kHz it was trained at
    normal = [f for f in files if "Normal" in f]
    (tmp_path / "n.csv").write_text("file,fs\n1797_Normal.npz,48000\n")
    capsys.readouterr()
    assert (
        main(
            [
                "predict",
                "--model",
                str(out / "model.pdmkit"),
                "--members",
                *normal,
                "--labels",
                str(tmp_path / "n.csv"),
                "--out",
                str(tmp_path / "p2"),
            ]
        )
        == 0
    )
    assert json.loads((tmp_path / "p2" / "summary.json").read_text())["n_members"] == 29
