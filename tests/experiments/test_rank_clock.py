"""``pdmkit rank`` with a prognostic method says when a top-ranked column is a clock.

PRONOSTIA's per-snapshot indicator file carries ``t_start_s_of_day``, which rises at
every snapshot but midnight: it ranked first by monotonicity (0.999) with no word.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from pdmkit.experiments._cli import main


def test_a_clock_column_is_named_and_a_noisy_indicator_is_not(tmp_path) -> None:
    rng = np.random.default_rng(0)
    n = 400
    seconds = (36000 + 10.0 * np.arange(n)) % 86400  # time of day, wraps once
    table = pd.DataFrame(
        {
            "snapshot": np.arange(1, n + 1),
            "t_start_s_of_day": seconds,
            "rms": 0.5 + 0.002 * np.arange(n) + rng.normal(0, 0.05, n),  # wears, noisy
            "kurtosis": rng.normal(0, 1, n),
        }
    )
    path = tmp_path / "features.csv"
    table.to_csv(path, index=False)
    out = tmp_path / "out"
    args = ["rank", "--features", str(path), "--method", "monotonicity"]
    assert main([*args, "--order", "snapshot", "--window", "20", "--out", str(out)]) == 0
    warned = json.loads((out / "summary.json").read_text())["warnings"]
    assert (
        len(warned) == 1 and "'t_start_s_of_day' is monotonic in the raw rows" in warned[0]
    )
