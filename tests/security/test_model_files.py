"""Hostile model files: each is refused with ModelError, runs nothing, stays bounded.

The attacks are the ones an independent review used against pdmkit's loader (it ran a
shell command through two of them), plus the classic archive attacks. Every hostile
file carries *valid* internal checksums: those only detect damage, so the refusal must
come from the loader's own rules (an exact class registry, declared sizes, bounded
nesting), never from a checksum.

Each case is loaded in a child process that reports its peak memory (VmHWM) and
time, so a decompression bomb that got through would show, and so a marker file that a
successful attack writes would be seen.
"""

from __future__ import annotations

import hashlib
import io
import json
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

from pdmkit._persist import load_model, object_registry, save_model
from pdmkit.errors import ModelError

#: What loading a hostile file may add to the loader's own imports (torch, scikit-learn
#: and skops take 400-520 MB depending on the environment; the attacks took 1-6 GB).
ADDED_MB = 100
SECONDS = 5.0


# --------------------------------------------------------------------------- building
def _members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as zf:
        return {n: zf.read(n) for n in zf.namelist()}


def _write(path: Path, members: dict[str, bytes], *, manifest_changes=None) -> Path:
    """Write ``members`` as a model file whose manifest checksums match them."""
    members = dict(members)
    manifest = json.loads(members.pop("manifest.json"))
    manifest.update(manifest_changes or {})
    manifest["sha256"] = {n: hashlib.sha256(b).hexdigest() for n, b in members.items()}
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("manifest.json", json.dumps(manifest))
        for name, blob in members.items():
            zf.writestr(name, blob)
    return path


def _runs() -> pd.DataFrame:
    rng = np.random.default_rng(3)
    rows = []
    for u in range(6):
        t = np.arange(int(rng.integers(30, 50)))
        rows.append(
            pd.DataFrame(
                {"unit": u, "time": t, "hi": 0.03 * t + rng.normal(0, 0.05, t.size)}
            )
        )
    return pd.concat(rows, ignore_index=True)


def _real_object_model(folder: Path) -> Path:
    from pdmkit.rul import HealthIndicator, LinearDegradationModel, RULPipeline

    pipe = RULPipeline(HealthIndicator(["hi"]), LinearDegradationModel())
    return save_model(pipe.fit(_runs()), folder / "real.pdmkit")


def _hidden_in_real_model(real: Path, out: Path, node: dict) -> Path:
    """A real, working model whose state carries one extra attribute: ``node``."""
    members = _members(real)
    state = json.loads(members["state.json"])
    state["state"]["items"].append(["extra_", node])
    members["state.json"] = json.dumps(state).encode()
    return _write(out, members)


def _object_node(cls: str, args: list) -> dict:
    return {"t": "object", "class": cls, "args": {"t": "list", "items": args}}


def _top_level(real: Path, out: Path, cls: str, args: list) -> Path:
    members = _members(real)
    members["state.json"] = json.dumps(_object_node(cls, args)).encode()
    return _write(out, members, manifest_changes={"class": cls})


def _skops_with_calls(folder: Path, marker: Path) -> Path:
    """A real scikit-learn model whose skops schema calls numpy.savetxt to write a
    Python file and pdmkit's model-file loader to run it (the reviewer's attack)."""
    from sklearn.preprocessing import StandardScaler

    path = save_model(
        StandardScaler().fit(np.random.default_rng(0).random((20, 2))),
        folder / "skops_base.pdmkit",
    )
    members = _members(path)
    with zipfile.ZipFile(io.BytesIO(members["model.skops"])) as zf:
        inner = {n: zf.read(n) for n in zf.namelist()}
    schema = json.loads(inner["schema.json"])

    def json_node(value):
        return {
            "__class__": "str",
            "__module__": "builtins",
            "__loader__": "JsonNode",
            "content": json.dumps(value),
            "is_json": True,
        }

    script = folder / "evil_model.py"
    code = f"open({str(marker)!r}, 'w').write('ran')\n"
    write = {
        "__class__": "savetxt",
        "__module__": "numpy",
        "__loader__": "ConstructorFromReduceNode",
        "content": {
            "__class__": "tuple",
            "__module__": "builtins",
            "__loader__": "TupleNode",
            "content": [json_node(str(script)), json_node([code]), json_node("%s")],
        },
    }
    run = {
        "__class__": "load_model_file",
        "__module__": "pdmkit.models",
        "__loader__": "ConstructorFromReduceNode",
        "content": {
            "__class__": "tuple",
            "__module__": "builtins",
            "__loader__": "TupleNode",
            "content": [json_node(str(script))],
        },
    }
    schema["content"]["content"]["a_write"] = write
    schema["content"]["content"]["b_run"] = run
    inner["schema.json"] = json.dumps(schema).encode()
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as zf:
        for name, blob in inner.items():
            zf.writestr(name, blob)
    members["model.skops"] = buffer.getvalue()
    return _write(folder / "skops_calls.pdmkit", members)


def _deflate_bomb(out: Path, gigabytes: float = 3.0) -> Path:
    """A zip whose state.json inflates to ``gigabytes`` of zeros (about 3 MB on disk).

    The deflate stream is built from one fully-flushed 64 MiB block repeated, so the
    test makes it in a second without ever holding the inflated bytes.
    """
    chunk = bytes(64 << 20)
    n_chunks = round(gigabytes * 1e9 / len(chunk))
    comp = zlib.compressobj(9, zlib.DEFLATED, -15)
    block = comp.compress(chunk) + comp.flush(zlib.Z_FULL_FLUSH)
    tail = zlib.compressobj(9, zlib.DEFLATED, -15).flush(zlib.Z_FINISH)
    crc = 0
    for _ in range(n_chunks):
        crc = zlib.crc32(chunk, crc)
    size = n_chunks * len(chunk)
    data = block * n_chunks + tail
    name = b"state.json"
    local = (
        struct.pack(
            "<4s5H3L2H", b"PK\x03\x04", 20, 0, 8, 0, 0, crc, len(data), size, len(name), 0
        )
        + name
    )
    central = (
        struct.pack(
            "<4s6H3L5H2L",
            b"PK\x01\x02",
            20,
            20,
            0,
            8,
            0,
            0,
            crc,
            len(data),
            size,
            len(name),
            0,
            0,
            0,
            0,
            0,
            0,
        )
        + name
    )
    end = struct.pack(
        "<4s4H2LH", b"PK\x05\x06", 0, 0, 1, 1, len(central), len(local) + len(data), 0
    )
    out.write_bytes(local + data + central + end)
    return out


def _zip_slip(real: Path, out: Path) -> Path:
    members = _members(real)
    with zipfile.ZipFile(out, "w") as zf:
        for name, blob in members.items():
            zf.writestr(name, blob)
        zf.writestr("../../evil.py", b"print('x')")
    return out


def _deep_json(real: Path, out: Path, depth: int = 100_000) -> Path:
    members = _members(real)
    members["state.json"] = b"[" * depth + b"]" * depth
    return _write(out, members)


def _build(path: Path, members: dict[str, bytes], kind: str, cls: str) -> Path:
    """A model file from scratch (an attacker needs no real model to start from)."""
    manifest = {"format": "pdmkit.model", "format_version": 1, "class": cls, "kind": kind}
    return _write(path, {"manifest.json": json.dumps(manifest).encode(), **members})


def _npz(**arrays) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


_UNIT = "pdmkit.rul._base.Unit"


def _unit_holding(node: dict) -> bytes:
    state = {"t": "dict", "items": [["x", node]]}
    return json.dumps({"t": "object", "class": _UNIT, "state": state}).encode()


def _json_container_bomb(out: Path) -> Path:
    """60 MB of empty JSON lists (20 million; 1.9 GB parsed) in a 60 KB file."""
    text = b"[" + b",".join([b"[]"] * 20_000_000) + b"]"
    body = _unit_holding({"t": "list", "items": []}).replace(
        b'"items": []', b'"x": ' + text
    )
    return _build(out, {"state.json": body, "arrays.npz": _npz()}, "object", _UNIT)


def _parquet_bomb(out: Path) -> Path:
    """A table node whose Parquet bytes (4 KB, zstd) decode to 1 GiB of zeros."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = 1 << 22
    table = pa.table({"x": pa.array(np.zeros(rows, dtype=np.int64))})
    buffer = io.BytesIO()
    with pq.ParquetWriter(buffer, table.schema, compression="zstd") as writer:
        for _ in range(32):
            writer.write_table(table, row_group_size=rows)
    raw = np.frombuffer(buffer.getvalue(), np.uint8)
    body = _unit_holding({"t": "dataframe", "key": "a0"})
    return _build(out, {"state.json": body, "arrays.npz": _npz(a0=raw)}, "object", _UNIT)


def _torch_deflate_bomb(out: Path, n: int = 16000) -> Path:
    """torch.save's own archive rewritten with deflated records: 1 GB in 3 KB."""
    import torch

    buffer = io.BytesIO()
    torch.save({"weight": torch.zeros(n, n), "bias": torch.zeros(n)}, buffer)
    with zipfile.ZipFile(io.BytesIO(buffer.getvalue())) as src:
        inner = {i.filename: src.read(i.filename) for i in src.infolist()}
    packed = io.BytesIO()
    with zipfile.ZipFile(packed, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, blob in inner.items():
            zf.writestr(name, blob)
    config = json.dumps({"config": {"in_features": n, "out_features": n}}).encode()
    members = {"state.json": config, "tensors.pt": packed.getvalue()}
    return _build(out, members, "torch", "torch.nn.modules.linear.Linear")


def _torch_costly_config(out: Path) -> Path:
    """An LSTM of 300 000 layers: 1 KB on disk, minutes to build even on meta."""
    import torch

    buffer = io.BytesIO()
    torch.save({}, buffer)
    config = {"input_size": 4, "hidden_size": 4, "num_layers": 300_000}
    members = {
        "state.json": json.dumps({"config": config}).encode(),
        "tensors.pt": buffer.getvalue(),
    }
    return _build(out, members, "torch", "torch.nn.modules.rnn.LSTM")


def _malformed(out: Path) -> Path:
    """An object node without its state (was a raw KeyError and a traceback)."""
    body = _unit_holding(
        {"t": "object", "class": "sklearn.preprocessing._data.StandardScaler"}
    )
    return _build(out, {"state.json": body, "arrays.npz": _npz()}, "object", _UNIT)


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    """Every hostile file, each with the marker its attack would write."""
    folder = tmp_path_factory.mktemp("hostile")
    real = _real_object_model(folder)
    cases = {}

    def add(name, build):
        marker = folder / f"{name}.marker"
        cases[name] = (build(marker), marker)

    # 1. attribute walking through imported modules, hidden inside a real model
    add(
        "hidden_fileio_via_pdmkit_module",
        lambda m: _hidden_in_real_model(
            real,
            folder / "a.pdmkit",
            _object_node("pdmkit.ensembles._datasets.io.FileIO", [str(m), "w"]),
        ),
    )
    add(
        "hidden_popen_via_sklearn_module",
        lambda m: _hidden_in_real_model(
            real,
            folder / "b.pdmkit",
            _object_node(
                "sklearn.externals.array_api_compat.numpy.f2py.subprocess.Popen",
                [{"t": "list", "items": ["touch", str(m)]}],
            ),
        ),
    )
    # 2. plain dangerous names at top level
    add(
        "top_level_popen",
        lambda m: _top_level(
            real,
            folder / "c.pdmkit",
            "subprocess.Popen",
            [{"t": "list", "items": ["touch", str(m)]}],
        ),
    )
    add(
        "top_level_fileio",
        lambda m: _top_level(real, folder / "d.pdmkit", "io.FileIO", [str(m), "w"]),
    )
    add(
        "top_level_eval",
        lambda m: _top_level(
            real, folder / "e.pdmkit", "builtins.eval", [f"open({str(m)!r}, 'w')"]
        ),
    )
    add(
        "class_from_main",
        lambda m: _top_level(real, folder / "f.pdmkit", "__main__.Evil", [str(m)]),
    )
    # a registered class may not be *called* with the file's arguments
    add(
        "registered_class_called_with_args",
        lambda m: _top_level(
            real, folder / "g.pdmkit", "pdmkit.rul._pipeline.RULPipeline", [str(m)]
        ),
    )
    # 3. skops payload calling numpy / pdmkit functions
    add("skops_numpy_savetxt_then_pdmkit_loader", lambda m: _skops_with_calls(folder, m))
    # 4. archive attacks
    add("zip_slip_member_name", lambda m: _zip_slip(real, folder / "h.pdmkit"))
    add("deflate_bomb_3gb", lambda m: _deflate_bomb(folder / "i.pdmkit"))
    add("json_100000_deep", lambda m: _deep_json(real, folder / "j.pdmkit"))
    # found by the independent red team (issue 12 review, second round)
    add("json_20_million_lists", lambda m: _json_container_bomb(folder / "k.pdmkit"))
    add("parquet_bomb_in_arrays", lambda m: _parquet_bomb(folder / "l.pdmkit"))
    add("torch_deflated_records", lambda m: _torch_deflate_bomb(folder / "n.pdmkit"))
    add("torch_300000_layer_lstm", lambda m: _torch_costly_config(folder / "o.pdmkit"))
    add("object_node_without_state", lambda m: _malformed(folder / "p.pdmkit"))
    return real, cases


# --------------------------------------------------------------------------- tests
def test_the_real_model_the_attacks_hide_in_loads(hostile):
    real, _ = hostile
    model = load_model(real)
    assert model.predict(_runs()).to_pandas()["rul"].notna().all()


_CHILD = textwrap.dedent(
    """
    import json, sys, time
    from pdmkit._persist import load_model, object_registry
    from pdmkit.errors import ModelError
    import skops.io, torch  # the loader's own imports, before the baseline
    object_registry()
    base = peak_mb()
    for case, path in json.loads(sys.argv[1]):
        start = time.perf_counter()
        try:
            load_model(path)
            outcome = "loaded"
        except ModelError as exc:
            outcome = "ModelError: " + str(exc)
        except BaseException as exc:
            outcome = f"{type(exc).__name__}: {exc}"
        print(json.dumps({"case": case, "outcome": outcome, "peak_mb": peak_mb(),
                          "seconds": time.perf_counter() - start, "base_mb": base}),
              flush=True)
    """
)
CASES = [
    "hidden_fileio_via_pdmkit_module",
    "hidden_popen_via_sklearn_module",
    "top_level_popen",
    "top_level_fileio",
    "top_level_eval",
    "class_from_main",
    "registered_class_called_with_args",
    "skops_numpy_savetxt_then_pdmkit_loader",
    "zip_slip_member_name",
    "deflate_bomb_3gb",
    "json_100000_deep",
    "json_20_million_lists",
    "parquet_bomb_in_arrays",
    "torch_deflated_records",
    "torch_300000_layer_lstm",
    "object_node_without_state",
]


@pytest.fixture(scope="module")
def reports(hostile, tmp_path_factory, peak_mb_source):
    """Load every hostile file in one child process (in the order above); its
    per-case outcome, time and peak memory so far (peaks only grow, so each case's
    peak bounds it)."""
    _, cases = hostile
    cwd = tmp_path_factory.mktemp("cwd")
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            peak_mb_source + _CHILD,
            json.dumps([[c, str(cases[c][0])] for c in CASES]),
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
    )
    lines = [json.loads(x) for x in done.stdout.splitlines() if x.startswith("{")]
    return {r["case"]: r for r in lines}, done, cwd


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES)
def test_hostile_model_file_is_refused_runs_nothing_and_stays_bounded(
    hostile, reports, case
):
    _, cases = hostile
    path, marker = cases[case]
    by_case, done, cwd = reports
    assert case in by_case, f"the child died before {case}: {done.stderr[-2000:]}"
    report = by_case[case]
    assert report["outcome"].startswith("ModelError: "), report["outcome"]
    assert "\n" not in report["outcome"]  # one line
    assert str(path) in report["outcome"]  # names the file
    assert not marker.exists(), f"{case}: the attack ran"
    assert not (cwd / "evil.py").exists()
    assert report["seconds"] < SECONDS, report
    assert report["peak_mb"] - report["base_mb"] < ADDED_MB, report


def test_refusals_say_why(hostile):
    _, cases = hostile
    expected = {
        "hidden_fileio_via_pdmkit_module": "not one a pdmkit model file may rebuild",
        "top_level_popen": "'subprocess.Popen', which is not one",
        "class_from_main": "'__main__.Evil'",
        "registered_class_called_with_args": "only scikit-learn's Tree",
        "skops_numpy_savetxt_then_pdmkit_loader": "numpy.savetxt",
        "zip_slip_member_name": "unexpected member",
        "deflate_bomb_3gb": "decompression bomb",
        "json_100000_deep": "nests 100000 levels deep",
    }
    for case, words in expected.items():
        with pytest.raises(ModelError, match=None) as info:
            load_model(cases[case][0])
        assert words in str(info.value), (case, str(info.value))


def test_registry_is_exact_names_not_prefixes():
    registry = object_registry()
    assert "pdmkit.rul._pipeline.RULPipeline" in registry
    assert "sklearn.ensemble._bagging.BaggingClassifier" in registry
    from pdmkit._persist_tree import MOVED_CLASSES

    for name in registry:
        cls = registry[name]
        # each name is the class's own; an older name of a moved class maps to the
        # class at its exact new name (files saved before a module split still load)
        assert f"{cls.__module__}.{cls.__qualname__}" == MOVED_CLASSES.get(name, name)
        assert name.startswith(("pdmkit.", "sklearn."))
    assert set(MOVED_CLASSES.values()) <= set(registry)
    assert not any("PyFunc" in n for n in registry)  # metrics holding a Python function


def test_expect_sha256_catches_a_swapped_file(hostile, tmp_path):
    real, _ = hostile
    digest = hashlib.sha256(real.read_bytes()).hexdigest()
    assert load_model(real, expect_sha256=digest) is not None
    other = _real_object_model(tmp_path)  # a valid model, but not the one we saved
    with pytest.raises(ModelError, match="not the expected"):
        load_model(other, expect_sha256="0" * 64)


def test_a_ceiling_refuses_an_honest_model_larger_than_allowed(hostile, monkeypatch):
    real, _ = hostile
    monkeypatch.setenv("PDMKIT_MAX_MODEL_BYTES", "1000")
    with pytest.raises(ModelError, match="PDMKIT_MAX_MODEL_BYTES"):
        load_model(real)


def test_corrupt_deflate_stream_is_one_line(hostile, tmp_path):
    real, _ = hostile
    raw = bytearray(real.read_bytes())
    with zipfile.ZipFile(real) as zf:
        info = zf.getinfo("state.json")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    raw[start : start + 8] = b"\xff" * 8
    broken = tmp_path / "broken.pdmkit"
    broken.write_bytes(bytes(raw))
    with pytest.raises(ModelError) as info:
        load_model(broken)
    assert "\n" not in str(info.value) and str(broken) in str(info.value)


def test_torch_config_declaring_huge_layers_costs_nothing(tmp_path):
    torch = pytest.importorskip("torch")
    net = torch.nn.Linear(3, 2)
    path = save_model(
        net, tmp_path / "lin.pdmkit", config={"in_features": 3, "out_features": 2}
    )
    members = _members(path)
    members["state.json"] = json.dumps(
        {"config": {"in_features": 60_000, "out_features": 60_000}}
    ).encode()
    hostile = _write(tmp_path / "huge.pdmkit", members)
    with pytest.raises(ModelError, match="do not have the shapes"):
        load_model(hostile)


def test_the_training_run_reports_the_hash_that_later_proves_the_file(tmp_path, capsys):
    from pdmkit.experiments._cli import main

    rng = np.random.default_rng(4)
    rows = []
    for u in range(12):
        t = np.arange(int(rng.integers(40, 60)))
        hi = 0.02 * t * (1 + 0.1 * rng.normal()) + 0.02 * rng.normal(size=t.size)
        rows.append(pd.DataFrame({"unit": u, "time": t, "hi": hi}))
    table = pd.concat(rows, ignore_index=True)
    table.to_csv(tmp_path / "train.csv", index=False)
    out = tmp_path / "out"
    args = ["rul", "--train", str(tmp_path / "train.csv"), "--model", "linear-degradation"]
    assert main([*args, "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    digest = hashlib.sha256((out / "model.pdmkit").read_bytes()).hexdigest()
    assert summary["model_sha256"] == digest
    assert digest in capsys.readouterr().err
    history = tmp_path / "unit.csv"
    table[table.unit == 0].head(20).drop(columns="unit").to_csv(history, index=False)
    trained = ["rul", "--trained", str(out / "model.pdmkit"), "--history", str(history)]
    assert main([*trained, "--expect-sha256", digest]) == 0
    assert "RUL" in capsys.readouterr().out
    assert main([*trained, "--expect-sha256", "ab" * 32]) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "not the expected" in line and "Do not load it" in line
