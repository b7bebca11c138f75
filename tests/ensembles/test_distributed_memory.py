"""Bounded memory: streaming an on-disk ensemble 4x larger does not need more memory."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from pdmkit.ensembles import Ensemble
from pdmkit.ensembles._parquet import write_parquet_batches

SAMPLES = 25_000
CHILD = r"""
import json, resource, sys, tracemalloc
import numpy as np
from pdmkit.ensembles import Ensemble
from pdmkit.features import extract_ensemble
warm = Ensemble({"a": np.zeros((2, SAMPLES_)), "b": np.zeros((2, SAMPLES_))}, fs=1000.0)
extract_ensemble(warm)  # imports and caches before the baseline
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
tracemalloc.start()
table = extract_ensemble(sys.argv[1], batch_size=16)
peak = tracemalloc.get_traced_memory()[1]
grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base
print(json.dumps({"rows": len(table), "traced": peak, "rss_growth": grown * 1024}))
""".replace("SAMPLES_", str(SAMPLES))


def _write(path, n_members):
    def batches():
        rng = np.random.default_rng(n_members)
        for k in range(0, n_members, 32):
            ids = [f"m{i:05d}" for i in range(k, k + 32)]
            yield Ensemble(
                {"a": rng.normal(size=(32, SAMPLES)), "b": rng.normal(size=(32, SAMPLES))},
                fs=1000.0,
                conditions={"k": np.arange(32) % 3},
                member_ids=ids,
            )

    return write_parquet_batches(batches(), path)


def _measure(path):
    out = subprocess.run(
        [sys.executable, "-c", CHILD, str(path)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_memory_does_not_grow_with_the_ensemble(tmp_path):
    small, large = 96, 384
    bytes_large = large * 2 * SAMPLES * 8  # 154 MB of samples
    batch_bytes = 16 * 2 * SAMPLES * 8  # 6.4 MB
    a = _measure(_write(tmp_path / "small", small))
    b = _measure(_write(tmp_path / "large", large))
    assert (a["rows"], b["rows"]) == (small, large)
    # numpy memory: a few batches, whatever the ensemble size
    assert b["traced"] < 4 * batch_bytes
    # the process as a whole: 4x the data costs (almost) nothing more, and far less
    # than the data itself
    assert b["rss_growth"] < a["rss_growth"] + 32 * 2**20
    assert b["rss_growth"] < bytes_large / 2
