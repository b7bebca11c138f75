"""Recordings users hand to pdmkit are untrusted: bounded, clear, never costly to others.

Each case comes from the security / data-safety review: a 2 MB ``.npz`` member holding
a 2 GiB array drove ``pdmkit features --members good.npz bomb.npz`` to 8.6 GB and the
good member was the one skipped; a header-less PRONOSTIA snapshot became 170 "signals"
named after its first row; uneven time stamps were dropped in favour of the most
common rate; one text cell in a ``rul --train`` table silently dropped that sensor;
``--ensemble gcs://...`` without gcsfs printed a traceback.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import re
import struct
import subprocess
import sys
import textwrap
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from pdmkit.ensembles import Ensemble, read_mat, read_npz, read_table
from pdmkit.ensembles._member_files import read_members
from pdmkit.ensembles._parquet import url_filesystem
from pdmkit.errors import DataError, DataWarning
from pdmkit.experiments._cli import main

FS = 1000.0
GIB = 1 << 30
#: Zeros per deflate block of the bombs (a full flush makes every block identical).
_BLOCK = 1 << 24


def _one_line(exc: pytest.ExceptionInfo) -> str:
    text = str(exc.value)
    assert "\n" not in text, text
    return text


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert err, "nothing on stderr"
    assert "Traceback" not in "\n".join(err)
    return err[-1]


# --------------------------------------------------------------------------- bombs
def _deflated_zeros(prefix: bytes, zeros: int) -> bytes:
    """A raw deflate stream of ``prefix`` then ``zeros`` zero bytes, built in O(blocks).

    After a full flush deflate starts afresh, so each block of zeros compresses to the
    same bytes: compress one block and repeat it. Ends with an empty final block.
    """
    assert zeros % _BLOCK == 0
    head = zlib.compressobj(9, zlib.DEFLATED, -15)
    start = head.compress(prefix) + head.flush(zlib.Z_FULL_FLUSH)
    body = zlib.compressobj(9, zlib.DEFLATED, -15)
    block = body.compress(bytes(_BLOCK)) + body.flush(zlib.Z_FULL_FLUSH)
    return start + block * (zeros // _BLOCK) + b"\x03\x00"  # empty final block


def _checksum(func, prefix: bytes, zeros: int, start: int) -> int:
    value = func(prefix, start)
    block = bytes(_BLOCK)
    for _ in range(zeros // _BLOCK):
        value = func(block, value)
    return value


def _write_npz_bomb(path: Path, nbytes: int = 2 * GIB) -> None:
    """A valid .npz whose 'vib' entry inflates to ``nbytes`` of float64 zeros (~2 MB)."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (nbytes // 8,)}
    )
    prefix = header.getvalue()
    data = _deflated_zeros(prefix, nbytes)
    size = len(prefix) + nbytes
    crc = _checksum(zlib.crc32, prefix, nbytes, 0)
    name = b"vib.npy"
    zip64 = struct.pack("<HHQQ", 1, 16, size, len(data))
    local = struct.pack(
        "<IHHHHHIIIHH", 0x04034B50, 45, 0, 8, 0, 0x21, crc, 2**32 - 1, 2**32 - 1,
        len(name), len(zip64),
    )  # fmt: skip
    central = struct.pack(
        "<IHHHHHHIIIHHHHHII", 0x02014B50, 45, 45, 0, 8, 0, 0x21, crc, 2**32 - 1,
        2**32 - 1, len(name), len(zip64), 0, 0, 0, 0, 0,
    )  # fmt: skip
    offset = len(local) + len(name) + len(zip64) + len(data)
    directory = central + name + zip64
    end = struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, 1, 1, len(directory), offset, 0)
    path.write_bytes(local + name + zip64 + data + directory + end)
    with zipfile.ZipFile(path, "a") as archive:  # the sampling rate, as savez writes it
        with archive.open("fs.npy", "w") as f:
            np.lib.format.write_array(f, np.array(FS))


def _mat_element(mdtype: int, data: bytes) -> bytes:
    return struct.pack("<II", mdtype, len(data)) + data + bytes(-len(data) % 8)


def _write_mat_bomb(path: Path, nbytes: int = 2 * GIB) -> None:
    """A valid v5 .mat whose compressed variable 'vib' inflates to ``nbytes`` (~2 MB)."""
    n = nbytes // 8
    flags = _mat_element(6, struct.pack("<II", 6, 0))  # miUINT32: class mxDOUBLE
    dims = _mat_element(5, struct.pack("<ii", n, 1))  # miINT32
    name = _mat_element(1, b"vib")  # miINT8
    data_tag = struct.pack("<II", 9, nbytes)  # miDOUBLE, the zeros follow
    content = flags + dims + name + data_tag
    prefix = struct.pack("<II", 14, len(content) + nbytes) + content  # miMATRIX
    stream = (
        b"\x78\xda"
        + _deflated_zeros(prefix, nbytes)
        + struct.pack(">I", _checksum(zlib.adler32, prefix, nbytes, 1))
    )
    header = b"MATLAB 5.0 MAT-file, written by the pdmkit tests".ljust(116, b" ")
    header += bytes(8) + struct.pack("<H", 0x0100) + b"IM"
    fs = io.BytesIO()
    savemat(fs, {"fs": FS})
    path.write_bytes(
        header + struct.pack("<II", 15, len(stream)) + stream + fs.getvalue()[128:]
    )


def _write_parquet_bomb(path: Path) -> None:
    """A Parquet member whose text column decodes to ~2 GB: one 100 KiB string x 20000."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    n = 20_000
    label = pa.DictionaryArray.from_arrays(
        pa.array(np.zeros(n, dtype=np.int32)), pa.array(["x" * 102_400])
    )
    table = pa.table({"time": np.arange(n) / FS, "vib": np.zeros(n), "label": label})
    pq.write_table(table, path, store_schema=False)  # read back as plain text


def _write_good(path: Path, seed: int = 0) -> np.ndarray:
    t = np.arange(2048) / FS
    vib = np.sin(2 * np.pi * 50 * t) + 0.1 * np.random.default_rng(seed).normal(size=t.size)
    np.savez(path, vib=vib, fs=FS)
    return vib


_MEASURE = textwrap.dedent(
    """
    import json, sys, time
    from pdmkit.ensembles._member_files import read_members
    out = {}
    for good, bomb in zip(sys.argv[1::2], sys.argv[2::2]):
        start = time.perf_counter()
        ens, errors = read_members([good, bomb], on_error="skip", return_errors=True)
        out[bomb] = {
            "seconds": time.perf_counter() - start,
            "members": ens.member_ids.tolist(),
            "vib": ens.signal("vib")[0].tolist(),
            "errors": errors.to_dict(orient="records"),
        }
    out["peak_mb"] = peak_mb()
    print(json.dumps(out))
    """
)


@pytest.fixture(scope="module")
def bombs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("bombs")
    paths = {
        "npz": folder / "bomb.npz",
        "mat": folder / "bomb_mat.mat",
        "parquet": folder / "bomb_pq.parquet",
    }
    _write_npz_bomb(paths["npz"])
    _write_mat_bomb(paths["mat"])
    _write_parquet_bomb(paths["parquet"])
    return paths


def test_the_bombs_are_small_files_declaring_gigabytes(bombs):
    # the npz entry declares 2 GiB and its zip entry says so too (a valid archive)
    with zipfile.ZipFile(bombs["npz"]) as archive:
        info = archive.getinfo("vib.npy")
        assert info.file_size > 2 * GIB and info.compress_size < 3 << 20
        with archive.open(info) as f:  # the first MiB inflates to the header + zeros
            head = f.read(1 << 20)
    assert head.startswith(b"\x93NUMPY") and head.count(0) > (1 << 20) - 200
    assert bombs["npz"].stat().st_size < 3 << 20
    assert bombs["mat"].stat().st_size < 3 << 20
    assert bombs["parquet"].stat().st_size < 1 << 20


def test_a_decompression_bomb_is_refused_and_the_good_member_kept(
    bombs, tmp_path, peak_mb_source
):
    """A 2 MB member holding 2 GiB: refused with its reason before anything is allocated;
    the good member is read as if the bomb were not there (< 500 MB, < 5 s)."""
    good = tmp_path / "good.npz"
    vib = _write_good(good)
    script = tmp_path / "measure.py"
    script.write_text(peak_mb_source + _MEASURE)
    args = []
    for kind in ("npz", "mat", "parquet"):
        args += [str(good), str(bombs[kind])]
    done = subprocess.run(
        [sys.executable, str(script), *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["peak_mb"] < 500, result["peak_mb"]
    reasons = {
        "npz": "array 'vib' (float64 of shape (268435456,)) declares 2 GiB decompressed",
        "mat": "variable 'vib' (shape (268435456, 1)) declares 2 GiB decompressed",
        "parquet": "text column 'label' decodes to 1.91 GiB",
    }
    for kind, reason in reasons.items():
        read = result[str(bombs[kind])]
        assert read["seconds"] < 5, (kind, read["seconds"])
        assert read["members"] == ["good"], kind
        np.testing.assert_array_equal(read["vib"], vib)
        (error,) = read["errors"]
        assert error["source"] == str(bombs[kind])
        assert reason in error["error"], error["error"]
        assert "more than the 1 GiB" in error["error"]
        assert "PDMKIT_MAX_MEMBER_BYTES=" in error["error"]
        assert error["error"].endswith("member skipped")


def test_cli_features_skips_the_bomb_and_exits_3(bombs, tmp_path, capsys):
    good = tmp_path / "good.npz"
    _write_good(good)
    out = tmp_path / "out"
    status = main(
        ["features", "--members", str(good), str(bombs["npz"]), "--out", str(out)]
    )
    assert status == 3
    assert "1 member(s) skipped for bad input, e.g. " in _error_line(capsys)
    errors = pd.read_parquet(out / "errors.parquet")
    assert errors["member"].tolist() == ["bomb"]
    assert "declares 2 GiB decompressed" in errors["error"].iloc[0]
    assert pd.read_parquet(out / "features.parquet").index.tolist() == ["good"]


def test_an_npz_header_declaring_more_than_its_entry_holds(tmp_path):
    # a few hundred bytes that declare a 16 GiB array: refused from the header alone
    path = tmp_path / "liar.npz"
    with zipfile.ZipFile(path, "w") as archive, archive.open("vib.npy", "w") as f:
        np.lib.format.write_array_header_1_0(
            f, {"descr": "<f8", "fortran_order": False, "shape": (2 * GIB,)}
        )
        f.write(bytes(64))
    with pytest.raises(DataError) as exc:
        read_npz(path)
    assert "liar.npz: array 'vib' (float64 of shape (2147483648,)) declares 16 GiB" in (
        _one_line(exc)
    )
    # under the ceiling, but the entry holds less than the header says: damaged
    with zipfile.ZipFile(path, "w") as archive, archive.open("vib.npy", "w") as f:
        np.lib.format.write_array_header_1_0(
            f, {"descr": "<f8", "fortran_order": False, "shape": (1000,)}
        )
        f.write(bytes(64))
    with pytest.raises(DataError) as exc:
        read_npz(path)
    assert "declares 7.81 KiB of data, but its zip entry holds 64 bytes" in _one_line(exc)


def test_the_ceiling_is_per_array_and_per_file(tmp_path, monkeypatch):
    monkeypatch.setenv("PDMKIT_MAX_MEMBER_BYTES", str(100_000))
    path = tmp_path / "rec.npz"
    np.savez(path, a=np.zeros(10_000), b=np.zeros(10_000))  # 80 kB each, 160 kB together
    with pytest.raises(DataError) as exc:
        read_npz(path)
    assert "rec.npz: its 2 arrays together declares 156 KiB decompressed" in _one_line(exc)
    np.savez(path, a=np.zeros(10_000))
    assert read_npz(path)["a"].shape == (10_000,)
    # an int8 signal fits as stored, but not as the float64 samples of a member
    np.savez(path, a=np.zeros(20_000, dtype=np.int8), fs=FS)
    with pytest.raises(DataError) as exc:
        read_members([path])
    assert "signal 'a' (20000 samples as float64) takes 156 KiB decompressed" in (
        _one_line(exc)
    )


def test_mat_variables_declared_or_decompressed_over_the_ceiling(tmp_path, monkeypatch):
    monkeypatch.setenv("PDMKIT_MAX_MEMBER_BYTES", str(1 << 20))
    path = tmp_path / "rig.mat"
    savemat(path, {"u": np.zeros((300_000, 1))}, do_compression=True)  # 2.3 MiB declared
    with pytest.raises(DataError) as exc:
        read_mat(path)
    assert "rig.mat: variable 'u' (shape (300000, 1)) declares 2.29 MiB" in _one_line(exc)
    # in a struct the shape says nothing (1x1): the decompressed size is counted
    savemat(path, {"s": {"u": np.zeros(300_000)}}, do_compression=True)
    with pytest.raises(DataError) as exc:
        read_mat(path)
    assert re.search(
        r"rig\.mat: variable 's' decompresses to at least [\d.]+ MiB", _one_line(exc)
    )
    # uncompressed: the size on disk
    savemat(path, {"u": np.zeros(300_000)})
    with pytest.raises(DataError, match=r"variable 'u' \(shape \(1, 300000\)\) declares"):
        read_mat(path)
    savemat(path, {"u": np.arange(1000.0), "Ts": 4.0}, do_compression=True)
    np.testing.assert_array_equal(read_mat(path)["u"], np.arange(1000.0))


def test_parquet_columns_declared_over_the_ceiling(tmp_path, monkeypatch):
    monkeypatch.setenv("PDMKIT_MAX_MEMBER_BYTES", str(1 << 20))
    path = tmp_path / "t.parquet"
    pd.DataFrame(
        {"x": np.zeros(200_000), "y": np.ones(10)[np.zeros(200_000, int)]}
    ).to_parquet(path)
    assert path.stat().st_size < 50_000  # all zeros and ones: tiny on disk
    with pytest.raises(DataError) as exc:
        read_table(path)
    assert "t.parquet: column 'x' declares 1.53 MiB decompressed" in _one_line(exc)
    # an ensemble part: every row group of every signal is checked before reading
    ens = Ensemble({"vib": np.zeros((2, 100_000))}, fs=FS)
    root = ens.to_parquet(tmp_path / "ens")
    with pytest.raises(DataError) as exc:
        Ensemble.from_parquet(root)
    assert "part-00000.parquet: row group 0 of column 'vib' declares 1.53 MiB" in (
        _one_line(exc)
    )
    # the streamed path (features --ensemble DIR, Dask partitions) checks it too
    from pdmkit.ensembles import parquet_partitions, read_partition

    with pytest.raises(DataError) as exc:
        read_partition(parquet_partitions(str(root), batch_size=2)[0])
    assert "part-00000.parquet: row group 0 of column 'vib' declares 1.53 MiB" in (
        _one_line(exc)
    )
    monkeypatch.delenv("PDMKIT_MAX_MEMBER_BYTES")
    assert len(Ensemble.from_parquet(root)) == 2
    assert len(read_partition(parquet_partitions(str(root), batch_size=2)[0])) == 2


def test_a_compressed_csv_bomb_is_counted_not_kept(tmp_path, monkeypatch):
    monkeypatch.setenv("PDMKIT_MAX_MEMBER_BYTES", str(1 << 20))
    import gzip

    path = tmp_path / "big.csv.gz"
    with gzip.open(path, "wb") as f:
        f.write(b"vib\n" + b"0\n" * 1_000_000)
    with pytest.raises(DataError) as exc:
        read_table(path)
    assert re.search(
        r"big\.csv\.gz: the CSV text decompresses to at least [\d.]+ MiB", _one_line(exc)
    )


# --------------------------------------------------------------------------- damage
def _corrupt_npz(path: Path, good: np.ndarray) -> None:
    np.savez_compressed(path, vib=good, fs=FS)
    raw = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo("vib.npy")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    for i in range(200, 260):  # scramble the middle of the deflate stream
        raw[start + i] ^= 0x55
    path.write_bytes(bytes(raw))


def test_a_corrupt_deflate_stream_is_one_line_naming_the_member(tmp_path):
    path = tmp_path / "corrupt.npz"
    _corrupt_npz(path, np.sin(np.arange(20_000) / 10.0))
    with pytest.raises(DataError) as exc:
        read_npz(path)
    message = _one_line(exc)
    assert f"{path}: array 'vib' is damaged: its compressed data does not decompress" in (
        message
    )
    assert "(zlib.error: " in message and "re-save or re-copy the archive" in message
    # a .mat variable too
    mat = tmp_path / "corrupt.mat"
    savemat(mat, {"vib": np.sin(np.arange(20_000) / 10.0)}, do_compression=True)
    raw = bytearray(mat.read_bytes())
    for i in range(400, 460):
        raw[i] ^= 0x55
    mat.write_bytes(bytes(raw))
    with pytest.raises(DataError) as exc:
        read_mat(mat)
    assert f"{mat}: variable 'vib' is damaged: its compressed data does not" in (
        _one_line(exc)
    )


def test_a_bad_member_never_costs_a_good_one(bombs, tmp_path):
    """Every kind of bad member is skipped with its reason; the good members are exactly
    what they are without the bad files."""
    good, bad = tmp_path / "good", tmp_path / "bad"
    good.mkdir()
    bad.mkdir()
    t = np.arange(2048) / FS
    rng = np.random.default_rng(3)
    for i in range(3):
        frame = pd.DataFrame({"time": t, "vib": rng.normal(size=t.size), "fault": "ok"})
        for folder in (good, bad):
            frame.to_csv(folder / f"g{i}.csv", index=False)
    for folder in (good, bad):
        _write_good(folder / "g3.npz", seed=4)
    (bad / "b_bomb.npz").symlink_to(bombs["npz"])
    _corrupt_npz(bad / "b_corrupt.npz", np.sin(np.arange(20_000) / 10.0))
    repeat = pd.DataFrame({"time": t, "vib": rng.normal(size=t.size), "fault": "ok"})
    repeat.loc[10, "time"] = repeat.loc[9, "time"]
    repeat.to_csv(bad / "b_time.csv", index=False)
    text = pd.DataFrame({"time": t, "vib": rng.normal(size=t.size).astype(object)})
    text.loc[700, "vib"] = "err"
    text.to_csv(bad / "b_text.csv", index=False)

    ens, errors = read_members(bad, on_error="skip", return_errors=True)
    clean = read_members(good)
    assert ens.member_ids.tolist() == clean.member_ids.tolist() == ["g0", "g1", "g2", "g3"]
    for a, b in zip(ens.signal("vib"), clean.signal("vib"), strict=True):
        np.testing.assert_array_equal(a, b)
    assert ens.fs == clean.fs == {"vib": FS}
    reasons = dict(zip(errors["member"], errors["error"], strict=True))
    assert set(reasons) == {"b_bomb", "b_corrupt", "b_time", "b_text"}
    assert "declares 2 GiB decompressed" in reasons["b_bomb"]
    assert "array 'vib' is damaged" in reasons["b_corrupt"]
    assert "time repeats at line 12" in reasons["b_time"]
    assert "column 'vib' mixes numbers and text" in reasons["b_text"]
    assert all("\n" not in r and r.endswith("member skipped") for r in reasons.values())


# --------------------------------------------------------------------------- header-less
def _first_line_numbers(path: Path) -> list[float]:
    with path.open(newline="") as f:
        return [float(v) for v in next(csv.reader(f))]


@pytest.mark.real_data
def test_a_headerless_pronostia_snapshot_is_read_with_its_first_row(require_data):
    path = require_data("femto_pronostia_bearing1_1") / "raw_subset" / "acc_00001.csv"
    with pytest.warns(DataWarning) as caught:
        table = read_table(path)
    (warning,) = [w for w in caught if issubclass(w.category, DataWarning)]
    message = str(warning.message)
    assert str(path) in message and "read as data, not as column names" in message
    assert "column_0 ... column_5" in message and "names=[...]" in message
    assert table.columns.tolist() == [f"column_{k}" for k in range(6)]
    # the README: 2560 samples per snapshot; every cell a number
    assert table.shape == (2560, 6) and table.notna().all().all()
    np.testing.assert_array_equal(table.iloc[0].to_numpy(), _first_line_numbers(path))
    with path.open() as f:
        last = [float(v) for v in f.read().strip().splitlines()[-1].split(",")]
    np.testing.assert_array_equal(table.iloc[-1].to_numpy(), last)


@pytest.mark.real_data
def test_cli_features_on_a_headerless_snapshot(require_data, tmp_path, capsys):
    path = require_data("femto_pronostia_bearing1_1") / "raw_subset" / "acc_00001.csv"
    out = tmp_path / "out"
    with pytest.warns(DataWarning, match="acc_00001.csv"):
        status = main(
            ["features", "--members", str(path), "--fs", "25600", "--out", str(out)]
        )
    assert status == 0
    capsys.readouterr()
    summary = json.loads((out / "summary.json").read_text())
    signals = {c.split("/")[0] for c in summary["features"]}
    # the two accelerations; the clock columns (hour, minute, second, us) are time
    assert signals == {"column_4", "column_5"}


def test_headerless_detection_and_its_limits(tmp_path):
    path = tmp_path / "h.csv"
    path.write_text("1.5,2,-3e-2\n4,5,6\n")
    with pytest.warns(DataWarning, match=r"h\.csv: the first line \('1\.5,2,-3e-2'\)"):
        table = read_table(path)
    assert table.columns.tolist() == ["column_0", "column_1", "column_2"]
    assert table.to_numpy().tolist() == [[1.5, 2.0, -0.03], [4.0, 5.0, 6.0]]
    # pandas' own header of unnamed columns stays a header
    pd.DataFrame(np.ones((2, 3))).to_csv(path, index=False)
    assert read_table(path).columns.tolist() == ["0", "1", "2"]
    # the caller decides when names or header are given
    path.write_text("1,2\n3,4\n")
    assert read_table(path, header=0).columns.tolist() == ["1", "2"]
    assert read_table(path, names=["a", "b"]).shape == (2, 2)
    # one named column is enough to make the first line a header
    path.write_text("t,2\n3,4\n")
    assert read_table(path).columns.tolist() == ["t", "2"]


# --------------------------------------------------------------------------- time column
def _member(path: Path, time: np.ndarray) -> None:
    pd.DataFrame({"time": time, "vib": np.sin(np.arange(time.size))}).to_csv(
        path, index=False
    )


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ("repeat", "time repeats at line 12: 0.009 s after 0.009 s on the row before"),
        ("back", "time goes back at line 23: 0.02 s after 0.021 s on the row before"),
        ("gap", "time is not uniform at line 502: 0.501 s is 0.002 s after the row"),
        ("jitter", "time is not uniform at line 302: 0.3003 s is 0.0013 s after"),
        ("empty", "time column 'time' has no valid time at line 42 (found 'nan')"),
    ],
)
def test_a_bad_time_column_names_the_file_and_line(tmp_path, change, expected):
    t = np.arange(1000) / FS
    if change == "repeat":
        t[10] = t[9]
    elif change == "back":
        t[[20, 21]] = t[[21, 20]]
    elif change == "gap":
        t = np.r_[t[:500], t[501:], t[-1] + 1 / FS]
    elif change == "jitter":
        t[300] += 0.3e-3
    else:
        t[40] = np.nan
    path = tmp_path / f"{change}.csv"
    _member(path, t)
    with pytest.raises(DataError) as exc:
        read_members([path])
    message = _one_line(exc)
    assert message.startswith(f"{path}: ") and expected in message
    assert "pass fs=" in message
    # the line the message names is the one holding that time stamp
    line = int(message.split(" at line ")[1].split(":")[0].split(" ")[0])
    cell = path.read_text().splitlines()[line - 1].split(",")[0]
    assert (
        cell == ""
        if change == "empty"
        else float(cell) == float(expected.split(": ")[1].split(" s")[0])
    )


def test_rounded_but_uniform_time_stamps_are_accepted(tmp_path):
    # 25.6 kHz written to the microsecond: steps of 39 and 40 us, uniform as recorded
    path = tmp_path / "us.csv"
    n = 4096
    _member(path, np.round(np.arange(n) / 25_600.0, 6))
    ens = read_members([path])
    assert ens.fs["vib"] == pytest.approx(25_600.0, rel=1e-5)
    # ISO timestamps at 10 Hz
    stamps = pd.date_range("2024-01-01", periods=50, freq="100ms")
    pd.DataFrame({"time": stamps.strftime("%Y-%m-%d %H:%M:%S.%f"), "vib": 1.0}).to_csv(
        path, index=False
    )
    assert read_members([path]).fs["vib"] == pytest.approx(10.0)


# --------------------------------------------------------------------------- text cells
def test_a_sensor_column_with_a_text_cell_is_refused(tmp_path):
    path = tmp_path / "run.csv"
    frame = pd.DataFrame(
        {"unit": 1, "cycle": np.arange(1, 21), "s1": np.linspace(0, 1, 20), "tag": "a"}
    )
    frame = frame.astype({"s1": object})
    frame.loc[13, "s1"] = "n.a."
    frame.to_csv(path, index=False)
    with pytest.raises(DataError) as exc:
        read_table(path)
    message = _one_line(exc)
    assert message.startswith(f"{path}: column 's1' mixes numbers and text")
    assert "19 cell(s) are numbers, 1 not (the first at line 15: 'n.a.')" in message
    assert path.read_text().splitlines()[14].split(",")[2] == "n.a."
    # the escape hatch the message names
    table = read_table(path, na_values=["n.a."])
    assert table["s1"].isna().sum() == 1 and table["s1"].dtype == float
    # a text column (labels) stays; so does a column read as text on purpose
    assert read_table(path, dtype={"s1": str})["tag"].eq("a").all()


def test_cli_rul_train_with_a_text_cell_exits_2(tmp_path, capsys):
    path = tmp_path / "train.csv"
    rows = []
    for unit in (1, 2, 3, 4):
        life = 30 + 5 * unit
        for cycle in range(1, life + 1):
            rows.append({"unit": unit, "cycle": cycle, "s1": cycle / life, "s2": 1.0})
    frame = pd.DataFrame(rows).astype({"s2": object})
    frame.loc[40, "s2"] = "?"
    frame.to_csv(path, index=False)
    status = main(["rul", "--train", str(path), "--out", str(tmp_path / "out")])
    assert status == 2
    line = _error_line(capsys)
    assert f"{path}: column 's2' mixes numbers and text" in line
    assert "(the first at line 42: '?')" in line
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------- URLs
@pytest.mark.parametrize(
    ("url", "expected"),
    [
        ("gcs://bucket/ens", "gcs://bucket/ens: the gcs:// filesystem is not installed"),
        ("nosuch://bucket/ens", "no filesystem is known for the protocol 'nosuch'"),
    ],
)
def test_an_fsspec_url_without_its_backend_is_one_line(url, expected, tmp_path, capsys):
    pytest.importorskip("fsspec")
    if url.startswith("gcs"):
        try:
            import gcsfs  # noqa: F401
        except ImportError:
            pass
        else:
            pytest.skip("gcsfs is installed here")
    with pytest.raises(DataError) as exc:
        url_filesystem(url)
    assert expected in _one_line(exc)
    if url.startswith("gcs"):
        assert "pip install gcsfs" in str(exc.value)
    status = main(["features", "--ensemble", url, "--out", str(tmp_path / "out")])
    assert status == 2
    assert expected in _error_line(capsys)


def test_a_member_with_thousands_of_columns_is_skipped_not_computed(tmp_path):
    """Red-team finding: a 35 KB CSV of 2000 three-sample columns cost 1 GB and a
    minute of indicators (10 000 columns: 3.9 GB, killed after 5 minutes)."""
    wide = tmp_path / "wide.csv"
    header = ",".join(["time"] + [f"c{i}" for i in range(2000)])
    rows = [",".join([f"{r * 0.001}"] + ["0.5"] * 2000) for r in range(3)]
    wide.write_text("\n".join([header, *rows]) + "\n")
    good = tmp_path / "good.csv"
    t = np.arange(256) / 1000.0
    pd.DataFrame({"time": t, "x": np.sin(40 * t)}).to_csv(good, index=False)
    ens, errors = read_members([good, wide], on_error="skip", return_errors=True)
    assert ens.member_ids.tolist() == ["good"]
    assert "2000 signal columns, more than the 1024" in errors["error"].iloc[0]


def test_a_member_holding_a_label_where_others_hold_a_signal_is_skipped(tmp_path):
    """Red-team finding: one such member stopped the whole read (exit 2, no table)."""
    t = np.arange(256) / 1000.0
    for i in range(3):
        pd.DataFrame({"time": t, "vib": np.sin(40 * t + i), "fault": "ok"}).to_csv(
            tmp_path / f"g{i}.csv", index=False
        )
    pd.DataFrame({"time": t, "vib": np.sin(40 * t), "fault": 1}).to_csv(
        tmp_path / "numlabel.csv", index=False
    )
    files = sorted(tmp_path.glob("*.csv"))
    ens, errors = read_members(files, on_error="skip", return_errors=True)
    assert sorted(ens.member_ids) == ["g0", "g1", "g2"]
    (error,) = errors["error"]
    assert "'fault' is a signal here but a label in 3 other member file(s)" in error


@pytest.mark.parametrize("fs", [np.nan, np.array([1000.0, 2000.0]), "1000", -5.0])
def test_a_sampling_rate_that_is_not_one_positive_number_is_named(tmp_path, fs):
    """Red-team finding: fs NaN or text was ignored (the majority rate used) and
    fs=[1000, 2000] became a two-sample signal; each is now the member's error."""
    rng = np.random.default_rng(0)
    np.savez(tmp_path / "good.npz", vib=rng.normal(size=500), fs=1000.0)
    np.savez(tmp_path / "odd.npz", vib=rng.normal(size=500), fs=fs)
    files = [tmp_path / "good.npz", tmp_path / "odd.npz"]
    ens, errors = read_members(files, on_error="skip", return_errors=True)
    assert ens.member_ids.tolist() == ["good"]
    assert "variable 'fs' should be the sampling rate" in errors["error"].iloc[0]


# --------------------------------------------------------------------------- red team 2
def _csv_member(path: Path, **signals: np.ndarray) -> None:
    t = np.arange(256) / FS
    pd.DataFrame({"time": t, **signals}).to_csv(path, index=False)


def test_a_csv_header_naming_a_column_twice_is_the_member_s_error(tmp_path):
    """Red-team finding: `time,vib,vib` was read with pandas' renamed signal 'vib.1'."""
    t = np.arange(256) / FS
    _csv_member(tmp_path / "good.csv", vib=np.sin(40 * t))
    rows = "\n".join(f"{x},{np.sin(x)},{np.cos(x)}" for x in t)
    (tmp_path / "dup.csv").write_text(f"time,vib,vib\n{rows}\n")
    ens, errors = read_members(tmp_path, on_error="skip", return_errors=True)
    assert ens.member_ids.tolist() == ["good"] and ens.signal_names == ["vib"]
    (error,) = errors["error"]
    assert "\n" not in error
    assert f"{tmp_path / 'dup.csv'}: the header names column 'vib' 2 times" in error
    assert "columns 2, 3" in error and "'vib.1'" in error
    with pytest.raises(DataError, match="names column 'vib' 2 times"):
        read_table(tmp_path / "dup.csv")
    # a column really named like pandas' renaming is no repeat
    (tmp_path / "dotted.csv").write_text(f"time,vib,vib.1\n{rows}\n")
    assert read_table(tmp_path / "dotted.csv").columns.tolist() == ["time", "vib", "vib.1"]


def _savez_or_mat(path: Path, data: dict) -> None:
    if path.suffix == ".mat":
        savemat(path, data)
    else:
        np.savez(path, **data)


@pytest.mark.parametrize("suffix", [".npz", ".mat"])
def test_a_complex_variable_is_refused_by_name(tmp_path, suffix):
    """Red-team finding: a complex signal was dropped silently (the member read
    without it)."""
    rng = np.random.default_rng(0)
    _savez_or_mat(tmp_path / f"good{suffix}", {"vib": rng.normal(size=500), "fs": FS})
    z = rng.normal(size=500) + 1j * rng.normal(size=500)
    _savez_or_mat(
        tmp_path / f"cplx{suffix}", {"vib": rng.normal(size=500), "z": z, "fs": FS}
    )
    ens, errors = read_members(tmp_path, on_error="skip", return_errors=True)
    assert ens.member_ids.tolist() == ["good"]
    (error,) = errors["error"]
    assert "\n" not in error
    assert f"cplx{suffix}: variable 'z' holds complex values" in error
    assert "real and imaginary parts as two signals" in error


@pytest.mark.parametrize("suffix", [".npz", ".mat"])
def test_a_boolean_signal_is_read_as_0_and_1_and_said(tmp_path, suffix):
    """Red-team finding: a true/false vector was dropped silently."""
    rng = np.random.default_rng(0)
    flag = rng.normal(size=500) > 0
    _savez_or_mat(
        tmp_path / f"b{suffix}", {"vib": rng.normal(size=500), "flag": flag, "fs": FS}
    )
    with pytest.warns(DataWarning) as seen:
        ens = read_members(tmp_path / f"b{suffix}")
    np.testing.assert_array_equal(ens.signal("flag")[0], flag.astype(float))
    (said,) = [str(w.message) for w in seen if "'flag'" in str(w.message)]
    assert "\n" not in said
    assert f"b{suffix}: variable 'flag' holds true/false values" in said
    assert "read as a signal of 0.0 and 1.0" in said


def test_a_true_false_csv_column_is_a_0_1_signal_not_a_text_error(tmp_path):
    flag = np.arange(256) % 3 == 0
    _csv_member(tmp_path / "b.csv", vib=np.sin(np.arange(256.0)), flag=flag)
    with pytest.warns(DataWarning, match=r"b\.csv: column 'flag' holds true/false"):
        ens = read_members(tmp_path / "b.csv")
    np.testing.assert_array_equal(ens.signal("flag")[0], flag.astype(float))


def test_mat_structs_cells_and_text_are_skipped_with_a_warning_naming_them(tmp_path):
    """Red-team finding: struct, cell and text variables vanished without a word."""
    rng = np.random.default_rng(0)
    for name in ("a", "b"):
        savemat(
            tmp_path / f"{name}.mat",
            {
                "vib": rng.normal(size=500),
                "fs": FS,
                "meta": {"gain": 2.0, "site": "pump 3"},
                "runs": np.array([np.arange(3.0), np.arange(4.0)], dtype=object),
                "names": np.array(["ab", "cd"]),
                "fault": "ir",
            },
        )
    with pytest.warns(DataWarning) as seen:
        ens = read_members(tmp_path)
    assert ens.member_ids.tolist() == ["a", "b"] and ens.signal_names == ["vib"]
    assert ens.conditions["fault"].tolist() == ["ir", "ir"]
    # a struct's fields are read as the file's variables (issue 32): here conditions
    assert ens.conditions[["gain", "site"]].values.tolist() == [[2.0, "pump 3"]] * 2
    said = [str(w.message) for w in seen]
    for name, what in [
        ("runs", "is a MATLAB cell or struct array"),
        ("names", "holds <U2 values"),
    ]:
        (line,) = [s for s in said if f"variable {name!r}" in s]  # once for both files
        assert line.startswith("2 member files (a.mat, b.mat): ") and what in line
        assert "skipped" in line and "\n" not in line


def test_an_npz_record_array_is_skipped_with_a_warning(tmp_path):
    rng = np.random.default_rng(0)
    record = np.zeros(3, dtype=[("gain", float), ("channel", int)])
    np.savez(tmp_path / "r.npz", vib=rng.normal(size=500), fs=FS, setup=record)
    with pytest.warns(DataWarning, match=r"r\.npz: variable 'setup' is a structured"):
        ens = read_members(tmp_path / "r.npz")
    assert ens.signal_names == ["vib"]


def test_a_folder_named_like_a_member_file_is_that_member_s_error(tmp_path):
    """Red-team finding: a folder `x.csv/` in a data folder was skipped silently."""
    data = tmp_path / "data"
    (data / "x.csv").mkdir(parents=True)
    (data / "notes").mkdir()
    _csv_member(data / "good.csv", vib=np.sin(np.arange(256.0)))
    _csv_member(data / "x.csv" / "inner.csv", vib=np.sin(np.arange(256.0)))
    for files in (data, data / "*.csv"):
        with pytest.warns(DataWarning) if files == data else _no_warning() as seen:
            ens, errors = read_members(files, on_error="skip", return_errors=True)
        assert ens.member_ids.tolist() == ["good"]
        (error,) = errors["error"]
        assert error.startswith(f"{data / 'x.csv'} is a folder, not a file")
        assert errors["member"].tolist() == ["x"]
        if files == data:
            (said,) = [str(w.message) for w in seen]
            assert "sub-folder(s) not read as members" in said and "notes" in said
    with pytest.raises(DataError, match=r"x\.csv is a folder, not a file"):
        read_members(data / "*.csv")  # on_error="raise"


@contextlib.contextmanager
def _no_warning():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield []
