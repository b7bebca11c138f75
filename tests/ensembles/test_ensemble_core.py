"""The in-memory Ensemble: construction, validation, selection, frames, resampling."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from pdmkit.ensembles import Ensemble
from pdmkit.errors import DataError


@pytest.fixture
def ens(rng: np.random.Generator) -> Ensemble:
    return Ensemble(
        {
            "vib": [rng.normal(size=400), rng.normal(size=400), rng.normal(size=600)],
            "temp": [np.arange(40.0), None, np.arange(60.0)],
        },
        fs={"vib": 100.0, "temp": 10.0},
        conditions={"label": ["ok", "worn", "ok"], "load": [1.0, 2.0, 3.0]},
        member_ids=["a", "b", "c"],
    )


# ---------------------------------------------------------------- construction


def test_construction_exposes_the_documented_api(ens: Ensemble) -> None:
    assert len(ens) == 3
    assert ens.signal_names == ["vib", "temp"]
    assert ens.fs == {"vib": 100.0, "temp": 10.0}
    assert isinstance(ens.member_ids, pd.Index)
    assert ens.member_ids.name == "member"
    assert ens.member_ids.tolist() == ["a", "b", "c"]
    assert ens.conditions.index.equals(ens.member_ids)
    assert ens.conditions["label"].tolist() == ["ok", "worn", "ok"]
    xs = ens.signal("vib")
    assert all(x.dtype == np.float64 and x.ndim == 1 for x in xs)
    assert ens.signal("temp")[1] is None
    assert "3 members" in repr(ens) and "temp" in repr(ens)


def test_default_member_ids_and_2d_input() -> None:
    data = np.arange(12, dtype=np.int32).reshape(3, 4)
    ens = Ensemble({"x": data}, fs=2)
    assert ens.member_ids.tolist() == ["m00000", "m00001", "m00002"]
    assert ens.fs == {"x": 2.0}
    np.testing.assert_array_equal(ens.signal("x")[1], [4.0, 5.0, 6.0, 7.0])
    assert ens.signal("x")[1].dtype == np.float64


def test_ids_from_a_conditions_index_named_member() -> None:
    cond = pd.DataFrame({"k": [1, 2]}, index=pd.Index(["u1", "u2"], name="member"))
    ens = Ensemble({"x": np.zeros((2, 3))}, fs=1.0, conditions=cond)
    assert ens.member_ids.tolist() == ["u1", "u2"]
    assert ens.conditions.columns.tolist() == ["k"]


def test_members_cannot_be_changed_through_returned_arrays(ens: Ensemble) -> None:
    x = ens.signal("vib")[0]
    with pytest.raises(ValueError, match="read-only"):
        x[0] = 1.0
    cond = ens.conditions
    cond["label"] = "changed"
    assert ens.conditions["label"].tolist() == ["ok", "worn", "ok"]


@pytest.mark.parametrize("bad, count, first", [(np.nan, 1, 17), (np.inf, 1, 17)])
def test_non_finite_samples_name_member_and_signal(
    bad: float, count: int, first: int
) -> None:
    x = np.zeros(50)
    x[first] = bad
    with pytest.raises(DataError) as info:
        Ensemble({"DE": [np.zeros(50), x]}, fs=1.0, member_ids=["ok", "IR_007/f012"])
    msg = str(info.value)
    assert "'DE'" in msg and "'IR_007/f012'" in msg
    assert f"{count} non-finite" in msg and f"first at sample {first}" in msg


def test_non_finite_in_a_2d_array_names_the_member() -> None:
    data = np.zeros((4, 10))
    data[2, [3, 5, 7]] = np.nan
    with pytest.raises(DataError, match=r"'FE' of member 'm00002' holds 3 non-finite"):
        Ensemble({"FE": data}, fs=1.0)


@pytest.mark.parametrize(
    "signals, match",
    [
        ({"x": [np.zeros((3, 2))]}, r"'x' of member 'm00000' must be 1-D"),
        ({"x": np.zeros(5)}, "must be a 2-D array"),
        ({"x": [np.array(["a", "b"])]}, "expected numbers"),
        ({"x": [np.zeros(3) + 1j]}, "complex"),
        ({"x": [np.zeros(0)]}, "no samples"),
        ({"x": [np.zeros(3)], "y": [np.zeros(3), np.zeros(3)]}, "disagree on the number"),
        ({"x": "abc"}, "must be a 2-D array or a sequence"),
    ],
)
def test_malformed_signals_are_rejected(signals: dict, match: str) -> None:
    with pytest.raises(DataError, match=match):
        Ensemble(signals, fs=1.0)


def test_malformed_conditions_fs_and_ids_are_rejected() -> None:
    x = np.zeros((2, 3))
    with pytest.raises(DataError, match="disagree on the number of members"):
        Ensemble({"x": x}, fs=1.0, conditions={"k": [1, 2, 3]})
    with pytest.raises(DataError, match="disagree"):
        Ensemble({"x": x}, fs=1.0, conditions=pd.DataFrame({"k": [1]}))
    with pytest.raises(DataError, match="unique"):
        Ensemble({"x": x}, fs=1.0, member_ids=["a", "a"])
    with pytest.raises(DataError, match="positive"):
        Ensemble({"x": x}, fs=0.0)
    with pytest.raises(DataError, match="no sampling rate for signal"):
        Ensemble({"x": x, "y": x}, fs={"x": 1.0})
    with pytest.raises(DataError, match="reserved"):
        Ensemble({"x": x}, fs=1.0, conditions={"member": [1, 2]}, member_ids=["a", "b"])
    with pytest.raises(DataError, match="name of a signal"):
        Ensemble({"x": x}, fs=1.0, conditions={"x": [1, 2]})


# ---------------------------------------------------------------- access


def test_has_signal_and_stack_handle_missing_members(ens: Ensemble) -> None:
    np.testing.assert_array_equal(ens.has_signal("temp"), [True, False, True])
    equal = ens.select(["a", "b"])
    data, mask = equal.stack("temp")
    assert mask.tolist() == [True, False]
    np.testing.assert_array_equal(data, np.arange(40.0)[None, :])
    data[0, 0] = 99.0  # stack returns a fresh array
    assert equal.signal("temp")[0][0] == 0.0


def test_stack_of_unequal_lengths_names_members_and_lengths(ens: Ensemble) -> None:
    with pytest.raises(DataError) as info:
        ens.stack("vib")
    msg = str(info.value)
    assert "400 samples" in msg and "600 samples" in msg and "'c'" in msg


def test_stack_when_no_member_has_the_signal() -> None:
    ens = Ensemble({"x": [None, None]}, fs=1.0)
    data, mask = ens.stack("x")
    assert data.shape == (0, 0) and not mask.any()


def test_unknown_signal_lists_the_known_ones(ens: Ensemble) -> None:
    with pytest.raises(DataError, match=r"no signal 'DE'.*'vib', 'temp'"):
        ens.signal("DE")


# ---------------------------------------------------------------- selection


def test_select_by_mask_ids_positions_slice_and_int(ens: Ensemble) -> None:
    assert ens.select(np.array([True, False, True])).member_ids.tolist() == ["a", "c"]
    assert ens.select(["c", "a"]).member_ids.tolist() == ["c", "a"]
    assert ens.select([2, 0]).member_ids.tolist() == ["c", "a"]
    assert ens.select(slice(1, 3)).member_ids.tolist() == ["b", "c"]
    assert ens.select(-1).member_ids.tolist() == ["c"]
    assert ens.select(ens.conditions["label"] == "ok").member_ids.tolist() == ["a", "c"]
    sub = ens.select(["c"])
    np.testing.assert_array_equal(sub.signal("temp")[0], np.arange(60.0))
    assert sub.conditions["load"].tolist() == [3.0]
    with pytest.raises(DataError, match="no member with id"):
        ens.select(["zz"])
    with pytest.raises(DataError, match="out of range"):
        ens.select(5)
    with pytest.raises(DataError, match="boolean selection has 2 entries"):
        ens.select(np.array([True, False]))


def test_batches_cover_all_members_in_order(ens: Ensemble) -> None:
    parts = list(ens.batches(2))
    assert [len(p) for p in parts] == [2, 1]
    assert [m for p in parts for m in p.member_ids] == ens.member_ids.tolist()
    with pytest.raises(DataError, match="size"):
        list(ens.batches(0))


# ---------------------------------------------------------------- frames


def test_frames_cut_all_signals_consistently_in_time_and_carry_labels(
    ens: Ensemble,
) -> None:
    fr = ens.frames(100)  # 1 s frames: 100 samples of vib, 10 of temp
    # a: 4 frames; b: 4 (vib only); c: 6
    assert len(fr) == 14
    cond = fr.conditions
    assert cond["source_member"].tolist() == ["a"] * 4 + ["b"] * 4 + ["c"] * 6
    assert cond["frame"].tolist() == [0, 1, 2, 3] * 2 + list(range(6))
    assert cond["label"].tolist() == ["ok"] * 4 + ["worn"] * 4 + ["ok"] * 6
    assert fr.member_ids[5] == "b/f0001"
    vib_c = ens.signal("vib")[2]
    np.testing.assert_array_equal(fr.signal("vib")[8 + 2], vib_c[200:300])
    np.testing.assert_array_equal(fr.signal("temp")[8 + 2], np.arange(20.0, 30.0))
    assert all(x is None for x in fr.signal("temp")[4:8])
    assert fr.fs == ens.fs


def test_frames_with_hop_overlap() -> None:
    x = np.arange(10.0)
    fr = Ensemble({"x": [x]}, fs=1.0).frames(4, hop=3)
    # starts 0, 3, 6 -> 3 frames
    assert [f.tolist() for f in fr.signal("x")] == [
        [0, 1, 2, 3],
        [3, 4, 5, 6],
        [6, 7, 8, 9],
    ]


def test_frames_number_limited_by_the_shortest_signal_in_time() -> None:
    ens = Ensemble(
        {"fast": [np.arange(100.0)], "slow": [np.arange(20.0)]},
        fs={"fast": 10.0, "slow": 1.0},
    )
    # fast covers 10 s, slow 20 s: 10 s -> 5 frames of 2 s
    fr = ens.frames(20)
    assert len(fr) == 5
    np.testing.assert_array_equal(fr.signal("slow")[4], [8.0, 9.0])


def test_frames_reject_short_members_by_name() -> None:
    ens = Ensemble(
        {"x": [np.zeros(100), np.zeros(30)]}, fs=1.0, member_ids=["long", "tiny"]
    )
    with pytest.raises(DataError) as info:
        ens.frames(50)
    assert "'tiny'" in str(info.value) and "30 samples" in str(info.value)
    assert "'long'" not in str(info.value)


def test_frames_reject_lengths_that_are_no_whole_number_of_samples() -> None:
    ens = Ensemble({"a": [np.zeros(30)], "b": [np.zeros(10)]}, fs={"a": 3.0, "b": 1.0})
    with pytest.raises(DataError, match="multiple of 3"):
        ens.frames(10)
    assert len(ens.frames(9)) == 3


def test_frames_of_a_signal_subset_drop_the_others(ens: Ensemble) -> None:
    fr = ens.select(["a", "c"]).frames(10, signals=["temp"])
    assert fr.signal_names == ["temp"]
    assert fr.fs == {"temp": 10.0}
    assert len(fr) == 4 + 6
    with pytest.raises(DataError, match="'b' have none of the signals"):
        ens.frames(10, signals="temp")


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 200),
    length=st.integers(1, 50),
    hop=st.integers(1, 50),
)
def test_frames_match_slices_of_the_recording(n: int, length: int, hop: int) -> None:
    x = np.arange(float(n))
    ens = Ensemble({"x": [x]}, fs=1.0)
    if n < length:
        with pytest.raises(DataError):
            ens.frames(length, hop=hop)
        return
    fr = ens.frames(length, hop=hop)
    starts = range(0, n - length + 1, hop)
    assert len(fr) == len(starts)
    for got, s in zip(fr.signal("x"), starts, strict=True):
        np.testing.assert_array_equal(got, x[s : s + length])


# ---------------------------------------------------------------- resampling


def test_resample_matches_scipy_resample_poly(rng: np.random.Generator) -> None:
    xs = [rng.normal(size=480), rng.normal(size=480), rng.normal(size=333), None]
    ens = Ensemble({"x": xs, "y": [np.ones(5)] * 4}, fs={"x": 48000.0, "y": 1.0})
    out = ens.resample(12000.0, signals="x")
    assert out.fs == {"x": 12000.0, "y": 1.0}
    for got, x in zip(out.signal("x"), xs, strict=True):
        if x is None:
            assert got is None
        else:
            np.testing.assert_allclose(
                got, scipy.signal.resample_poly(x, 1, 4), rtol=0, atol=1e-12
            )
    assert out.signal("y")[0] is ens.signal("y")[0]


def test_resample_to_a_non_integer_ratio(rng: np.random.Generator) -> None:
    x = rng.normal(size=1000)
    ens = Ensemble({"v": [x]}, fs=610.3515625)
    out = ens.resample(1000.0)
    expected = scipy.signal.resample_poly(x, 1024, 625)
    np.testing.assert_allclose(out.signal("v")[0], expected, atol=1e-12)


def test_resample_per_signal_mapping() -> None:
    ens = Ensemble({"a": np.ones((1, 8)), "b": np.ones((1, 8))}, fs=8.0)
    out = ens.resample({"a": 4.0})
    assert out.fs == {"a": 4.0, "b": 8.0}
    assert len(out.signal("a")[0]) == 4


# ---------------------------------------------------------------- conditions, concat


def test_with_conditions_adds_and_broadcasts(ens: Ensemble) -> None:
    out = ens.with_conditions(rpm=1797, unit=[1, 2, 3])
    assert out.conditions["rpm"].tolist() == [1797] * 3
    assert out.conditions["unit"].tolist() == [1, 2, 3]
    assert "rpm" not in ens.conditions.columns  # original untouched
    by_id = pd.Series([30, 10, 20], index=["c", "a", "b"])
    assert ens.with_conditions(k=by_id).conditions["k"].tolist() == [10, 20, 30]
    with pytest.raises(DataError, match="2 values"):
        ens.with_conditions(bad=[1, 2])


def test_concat_unites_signals_and_conditions(ens: Ensemble) -> None:
    other = Ensemble(
        {"vib": np.zeros((2, 50)), "extra": np.ones((2, 5))},
        fs={"vib": 100.0, "extra": 5.0},
        conditions={"label": ["new", "new"]},
        member_ids=["d", "e"],
    )
    both = Ensemble.concat([ens, other])
    assert both.member_ids.tolist() == ["a", "b", "c", "d", "e"]
    assert both.signal_names == ["vib", "temp", "extra"]
    assert both.has_signal("extra").tolist() == [False, False, False, True, True]
    assert both.conditions["label"].tolist() == ["ok", "worn", "ok", "new", "new"]
    assert np.isnan(both.conditions["load"].iloc[3])
    with pytest.raises(DataError, match="repeat"):
        Ensemble.concat([ens, ens])
    assert len(Ensemble.concat([ens, ens], keys=["x", "y"])) == 6
    slow = Ensemble({"vib": np.zeros((1, 5))}, fs=50.0, member_ids=["z"])
    with pytest.raises(DataError, match="resample"):
        Ensemble.concat([ens, slow])


def test_to_pandas_gives_conditions_and_lengths(ens: Ensemble) -> None:
    table = ens.to_pandas()
    assert table.columns.tolist() == ["label", "load", "vib", "temp"]
    assert table["vib"].tolist() == [400, 400, 600]
    assert table["temp"].iloc[0] == 40 and np.isnan(table["temp"].iloc[1])


def test_resample_mapping_must_cover_the_chosen_signals() -> None:
    ens = Ensemble({"a": np.ones((1, 8)), "b": np.ones((1, 8))}, fs=8.0)
    with pytest.raises(DataError, match="no target rate for signal"):
        ens.resample({"a": 4.0}, signals=["a", "b"])
    with pytest.raises(DataError, match="no signal 'c'"):
        ens.resample({"c": 4.0})


def test_pickle_round_trip_for_worker_processes(ens: Ensemble) -> None:
    import pickle

    back = pickle.loads(pickle.dumps(ens.frames(100)))
    orig = ens.frames(100)
    assert back.member_ids.equals(orig.member_ids) and back.fs == orig.fs
    pd.testing.assert_frame_equal(back.conditions, orig.conditions)
    for s in orig.signal_names:
        for x, y in zip(orig.signal(s), back.signal(s), strict=True):
            assert (x is None and y is None) or np.array_equal(x, y)
