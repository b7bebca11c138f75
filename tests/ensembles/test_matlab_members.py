"""MATLAB files as MATLAB users save them (issue 32, item 5).

Tables, timetables, strings and categoricals in v7 files (MCOS objects, read with
``mat-io``), v7.3 (HDF5) files (read with h5py), and the members they make: a timetable's
variables are signals at the rate of its row times, a one-row table's scalars the
member's conditions. The references are independent of the reader: the values the test
wrote, the source rig's CSV twin of its MATLAB recording, the rig's settings file.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from pdmkit.ensembles import read_mat, read_members
from pdmkit.errors import DataError, DataWarning

h5py = pytest.importorskip("h5py")
matio = pytest.importorskip("matio")

#: MATLAB's v7.3 header: 116 bytes of text, 8 of subsystem offset, version 0x0200, "IM".
V73_TEXT = (
    b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 "
    b"HDF5 schema 1.00 ."
)


def _v73(path: Path, write) -> Path:
    """An HDF5 file laid out as MATLAB's save(..., '-v7.3') writes it."""
    with h5py.File(path, "w", userblock_size=512) as f:
        write(f)
    with path.open("r+b") as fh:  # the userblock: MATLAB's 128-byte header
        fh.write(V73_TEXT.ljust(116, b" ") + bytes(8) + struct.pack("<H", 0x0200) + b"IM")
    return path


def _dataset(group, name: str, matlab_value: np.ndarray, cls: str):
    """A MATLAB array as MATLAB stores it: dimensions reversed (HDF5 is row-major)."""
    group[name] = np.asarray(matlab_value).T
    group[name].attrs["MATLAB_class"] = np.bytes_(cls)
    return group[name]


def _char(group, name: str, text: str):
    ds = _dataset(
        group, name, np.frombuffer(text.encode("utf-16-le"), "<u2")[None, :], "char"
    )
    ds.attrs["MATLAB_int_decode"] = np.int32(2)


def test_a_v73_file_of_numbers_and_a_struct_is_a_member(tmp_path):
    rng = np.random.default_rng(3)
    vib, acc = rng.normal(size=(800, 1)), rng.normal(size=(800, 1))
    matrix = np.arange(6.0).reshape(2, 3)

    def write(f):
        _dataset(f, "vib", vib, "double")
        _dataset(f, "fs", np.array([[2000.0]]), "double")
        _char(f, "fault", "inner race")
        setup = f.create_group("setup")
        setup.attrs["MATLAB_class"] = np.bytes_("struct")
        _dataset(setup, "acc", acc, "double")
        _dataset(setup, "load", np.array([[6.25]]), "double")
        ok = _dataset(setup, "ok", np.array([[1]], dtype=np.uint8), "logical")
        ok.attrs["MATLAB_int_decode"] = np.int32(1)

    path = _v73(tmp_path / "run1.mat", write)
    assert (
        path.read_bytes()[:10] == b"MATLAB 7.3" and path.read_bytes()[512:516] == b"\x89HDF"
    )
    data = read_mat(path)
    assert data["fault"] == "inner race" and data["setup"]["ok"] is True
    ens = read_members(path)
    assert sorted(ens.signal_names) == ["acc", "vib"]
    assert ens.fs == {"acc": 2000.0, "vib": 2000.0}
    np.testing.assert_array_equal(ens.signal("vib")[0], vib[:, 0])
    np.testing.assert_array_equal(ens.signal("acc")[0], acc[:, 0])
    conditions = ens.conditions.iloc[0]
    assert conditions[["fault", "load", "ok"]].tolist() == ["inner race", 6.25, True]
    # MATLAB's 2 x 3 matrix is stored 3 x 2 (HDF5 is row-major) and read back 2 x 3
    path = _v73(tmp_path / "m.mat", lambda f: _dataset(f, "M", matrix, "double"))
    with h5py.File(path) as f:
        assert f["M"].shape == (3, 2)
    assert read_mat(path)["M"].tolist() == matrix.tolist()


def test_v73_cells_resolve_their_references_and_a_dangling_one_is_named(tmp_path):
    def write(f, dangling=False):
        refs = f.create_group("#refs#")
        a = _dataset(refs, "a", np.arange(3.0)[None, :], "double")
        cell = np.array(
            [[a.ref, h5py.Reference() if dangling else a.ref]], dtype=h5py.ref_dtype
        )
        _dataset(f, "c", cell, "cell")
        _dataset(f, "vib", np.ones((50, 1)), "double")

    data = read_mat(_v73(tmp_path / "c.mat", write))
    assert [x.tolist() for x in data["c"]] == [[0.0, 1.0, 2.0]] * 2
    bad = _v73(tmp_path / "bad.mat", lambda f: write(f, dangling=True))
    with pytest.raises(DataError) as exc:
        read_mat(bad)
    message = str(exc.value)
    assert message.startswith(f"{bad}: variable 'c'") and "\n" not in message
    assert "object reference that cannot be resolved" in message and "re-save" in message


def test_v73_files_that_point_elsewhere_or_declare_too_much_are_refused(
    tmp_path, monkeypatch
):
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = np.zeros(4)
    path = _v73(
        tmp_path / "link.mat",
        lambda f: f.__setitem__("x", h5py.ExternalLink(str(other), "x")),
    )
    with pytest.raises(DataError, match=r"link\.mat: 'x' is a soft or external HDF5 link"):
        read_mat(path)
    monkeypatch.setenv("PDMKIT_MAX_MEMBER_BYTES", str(1 << 20))

    def huge(f):  # 80 MB declared, a few KB on disk: nothing is written to its chunks
        ds = f.create_dataset(
            "u", shape=(1, 10_000_000), dtype="f8", chunks=(1, 1000), compression="gzip"
        )
        ds.attrs["MATLAB_class"] = np.bytes_("double")

    path = _v73(tmp_path / "bomb.mat", huge)
    assert path.stat().st_size < 64 << 10
    with pytest.raises(
        DataError,
        match=r"bomb\.mat: HDF5 dataset 'u' \(shape \(1, 10000000\)\) declares 76\.3 MiB",
    ):
        read_mat(path)


def _tables(path: Path) -> dict:
    """MATLAB tables, timetables, strings and categoricals, as mat-io writes them."""
    t = pd.to_timedelta(np.arange(200) / 500.0, unit="s")
    tt = pd.DataFrame(
        {"vib": np.sin(np.arange(200) / 7.0), "cur": np.cos(np.arange(200.0))}, index=t
    )
    row = pd.DataFrame({"fault": ["outer"], "load": [3.5]})
    values = {
        "tt": tt,
        "info": row,
        "site": np.array(["pump 3"], dtype=np.dtypes.StringDType()),
        "grade": pd.Categorical(["b", "a", "b"]),
    }
    matio.save_to_mat(path, values, version="v7")
    return values


def test_v7_tables_timetables_strings_and_categoricals_are_read(tmp_path):
    path = tmp_path / "obj.mat"
    wrote = _tables(path)
    assert path.read_bytes()[126:128] == b"IM"  # a v5/v7 file, not HDF5
    data = read_mat(path)
    tt = data["tt"]
    assert tt.attrs["matlab_class"] == "timetable" and isinstance(
        tt.index, pd.TimedeltaIndex
    )
    pd.testing.assert_frame_equal(
        tt[["vib", "cur"]], wrote["tt"], check_names=False, check_freq=False
    )
    assert data["info"].to_dict("records") == [{"fault": "outer", "load": 3.5}]
    assert data["site"] == "pump 3"
    assert list(data["grade"]) == ["b", "a", "b"] and list(data["grade"].categories) == [
        "a",
        "b",
    ]
    with pytest.warns(DataWarning, match=r"variable 'grade' is a MATLAB categorical array"):
        ens = read_members(path)
    assert ens.fs == {"vib": 500.0, "cur": 500.0}
    np.testing.assert_array_equal(ens.signal("vib")[0], wrote["tt"]["vib"].to_numpy())
    assert ens.conditions.iloc[0][["fault", "load", "site"]].tolist() == [
        "outer",
        3.5,
        "pump 3",
    ]


def test_a_timetable_made_with_a_sample_rate_gets_that_rate():
    from pdmkit.ensembles._matlab_tables import convert

    class MatlabOpaque:  # as mat-io names its raw objects
        def __init__(self, classname, properties):
            self.classname, self.properties = classname, properties

    def record(**fields):
        out = np.empty((1, 1), dtype=[(k, object) for k in fields])
        for k, v in fields.items():
            out[0, 0][k] = v
        return out

    data = np.empty((1, 1), dtype=object)
    data[0, 0] = np.arange(5.0)[:, None]
    times = record(
        origin=MatlabOpaque("duration", {"millis": np.array([[250.0]])}),
        specifiedAsRate=np.array([[True]]),
        stepSize=MatlabOpaque("duration", {"millis": np.array([[4.0]])}),
        sampleRate=np.array([[250.0]]),
    )
    tt = record(
        minCompatibleVersion=np.array([[4.0]]),
        numRows=np.array([[5.0]]),
        varNames=np.array([[np.array(["x"])]], dtype=object),
        data=data,
        rowTimes=times,
        dimNames=np.array([[np.array(["Time"]), np.array(["Variables"])]], dtype=object),
    )
    frame = convert(MatlabOpaque("timetable", {"any": tt}), "t.mat", 1 << 20)
    assert frame.attrs["sample_rate"] == 250.0 and frame["x"].tolist() == [0, 1, 2, 3, 4]
    assert (frame.index / pd.Timedelta(seconds=1)).tolist() == [
        0.25,
        0.254,
        0.258,
        0.262,
        0.266,
    ]
    tt[0, 0]["numRows"] = np.array([[1e9]])  # more rows than its variables hold
    with pytest.raises(DataError, match=r"t\.mat \(timetable\): variable 'x' has 5 rows"):
        convert(MatlabOpaque("timetable", {"any": tt}), "t.mat", 1 << 40)


@pytest.mark.real_data
def test_the_rig_recording_matches_its_csv_twin(require_data):
    """The source rig's table of timetables: 16 signals (13 at 1 kHz in the CSV twin, 3
    microphones at 40 kHz) and the settings as conditions."""
    rig = require_data("pneumatic_rig")  # skips, saying why, without the shared data
    ens = read_members(rig / "data11_1_1.mat")
    csv = pd.read_csv(rig / "data11_1_1.csv")
    t = csv.pop("time").to_numpy()
    assert len(ens.signal_names) == 16 and set(csv.columns) < set(ens.signal_names)
    for name in csv.columns:
        assert ens.fs[name] == pytest.approx((len(t) - 1) / (t[-1] - t[0]))  # 1000 Hz
        np.testing.assert_allclose(
            ens.signal(name)[0], csv[name], rtol=1e-8, atol=1e-12, err_msg=name
        )
    for mic in ("MIC_uBumper", "MIC_bBumper", "MIC_Ambient"):
        assert ens.fs[mic] == 40_000.0 and len(ens.signal(mic)[0]) == 400_000
    settings = json.loads((rig / "data11_settings.json").read_text())["data11_1_1"]
    assert ens.conditions.iloc[0].to_dict() == pytest.approx(settings)


@pytest.mark.parametrize("kind", ["cell of strings", "containers.Map"])
def test_a_file_pdmkit_cannot_read_says_what_it_holds_and_what_to_do(tmp_path, kind):
    path = tmp_path / "odd.mat"
    if kind == "cell of strings":
        savemat(path, {"names": np.array(["ab", "cd", "efg"], dtype=object)})
        held = "'names' (cell 1x3)"
    else:
        from matio.utils import MatlabContainerMap

        matio.save_to_mat(path, {"m": MatlabContainerMap({"a": 1.0})}, version="v7")
        held = "'m' (containers.Map 1x1: a class pdmkit does not read)"
    with pytest.raises(DataError) as exc:
        read_members(path)
    message = str(exc.value)
    assert "\n" not in message and message.startswith(
        f"{path} holds no signal pdmkit reads"
    )
    assert (
        f"it holds {held}; save each signal as a numeric vector or a timetable" in message
    )
    assert "structured (record)" not in message and "'None'" not in message


def test_a_cell_array_declaring_more_cells_than_it_holds_is_refused(tmp_path):
    """A 200-byte file declaring 10**8 cells: numpy.empty of 10**8 objects (800 MB,
    filled) before the first cell is read, in scipy and mat-io alike."""
    path = tmp_path / "cells.mat"
    savemat(path, {"c": np.array([1.0, 2.0], dtype=object)}, do_compression=False)
    raw = bytearray(path.read_bytes())
    at = raw.index(struct.pack("<ii", 1, 2), 128)  # the cell's dimensions, 1 x 2
    raw[at : at + 8] = struct.pack("<ii", 1, 10**8)
    path.write_bytes(bytes(raw))
    with pytest.raises(
        DataError,
        match=r"variable 'c': a cell array declares 100000000 elements but holds \d+ bytes",
    ):
        read_mat(path)


def test_cells_nested_deeper_than_matlab_writes_are_refused(tmp_path):
    value: object = np.array([1.0])
    for _ in range(70):
        box = np.empty(1, dtype=object)
        box[0] = value
        value = box
    savemat(tmp_path / "deep.mat", {"d": value})
    with pytest.raises(
        DataError,
        match=r"deep\.mat as a MATLAB file \(variable 'd': arrays nest deeper than 64",
    ):
        read_mat(tmp_path / "deep.mat")


def _corrupt_numeric(path: Path) -> None:
    """A double array whose data element states data type 0xFB09."""
    savemat(path, {"x": np.arange(5.0)}, do_compression=False)
    raw = bytearray(path.read_bytes())
    raw[raw.index(struct.pack("<II", 9, 40)) + 1] = 0xFB
    path.write_bytes(bytes(raw))


def _corrupt_dims(path: Path) -> None:
    """A char array whose dimensions shrink to a 1-byte small element (no dims)."""
    savemat(path, {"t": "text"}, do_compression=False)
    raw = bytearray(path.read_bytes())
    header = bytes.fromhex("060000000800000004000000000000000500000008000000")
    raw[raw.index(header) + 18] = 1
    path.write_bytes(bytes(raw))


def _corrupt_metadata(path: Path) -> None:
    """A timetable whose object metadata is flagged complex: its imaginary part is
    read from the bytes after it."""
    t = pd.to_timedelta(np.arange(4) / 10.0, unit="s")
    tt = pd.DataFrame({"v": np.arange(4.0)}, index=t)
    matio.save_to_mat(path, {"tt": tt}, version="v7", do_compression=False)
    raw = bytearray(path.read_bytes())
    raw[raw.index(bytes.fromhex("06000000080000000d00000000000000"), 128) + 9] = 0x3B
    path.write_bytes(bytes(raw))


@pytest.mark.parametrize("corrupt", [_corrupt_numeric, _corrupt_dims, _corrupt_metadata])
def test_files_that_crash_the_decoders_are_refused_first(tmp_path, corrupt):
    """Each of these made scipy.io.loadmat or mat-io read out of bounds (a segmentation
    fault or bus error, found by mutating files); the walk refuses them first."""
    path = tmp_path / "bad.mat"
    corrupt(path)
    with pytest.raises(DataError) as exc:
        read_mat(path)
    message = str(exc.value)
    assert message.startswith(f"cannot read {path} as a MATLAB file (variable ")
    assert (
        message.endswith("the file is damaged or not a .mat file") and "\n" not in message
    )


def test_an_empty_char_array_of_a_billion_rows_is_refused(tmp_path):
    """0 bytes of text in 10**9 rows decodes to 10**9 strings (3.7 GiB of numpy's
    4-byte characters) in scipy and mat-io alike: what a char array declares counts."""
    path = tmp_path / "text.mat"
    empty = np.zeros((3, 0), dtype="U1")
    savemat(path, {"c": np.array([empty, 1.0], dtype=object)}, do_compression=False)
    raw = bytearray(path.read_bytes())
    char = bytes.fromhex("040000000000000005000000080000000000000000000000")
    at = raw.index(char) + 16
    raw[at : at + 4] = struct.pack("<i", 10**9)  # its dimensions: 10**9 x 0
    path.write_bytes(bytes(raw))
    with pytest.raises(DataError) as exc:
        read_mat(path)
    assert str(exc.value).startswith(
        f"{path}: variable 'c' (a char array of shape (1000000000, 0) inside it) "
        "declares 3.73 GiB decompressed"
    )
