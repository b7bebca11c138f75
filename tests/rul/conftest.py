"""Shared fixtures of the RUL tests."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest


def _tables(seed=0, n_train=24, n_test=8):
    rng = np.random.default_rng(seed)

    def units(n, cut):
        rows = []
        for u in range(n):
            life = int(rng.integers(70, 120))
            t = np.arange(1, life + 1)
            stop = life - int(rng.integers(5, 50)) if cut else life
            frac = t / life
            rows.append(
                pd.DataFrame(
                    {
                        "unit": u + 1,
                        "cycle": t[:stop],
                        "setting_1": rng.normal(0, 1e-3, life)[:stop],
                        "s1": (frac**2 + rng.normal(0, 0.03, life))[:stop],
                        "s2": (1 - frac**3 + rng.normal(0, 0.03, life))[:stop],
                        "rul_true_final": life - stop,
                    }
                )
            )
        return pd.concat(rows, ignore_index=True)

    train = units(n_train, False).drop(columns="rul_true_final")
    return train, units(n_test, True)


@pytest.fixture
def rul_tables():
    """``(train, test)`` long tables of synthetic run-to-failure units (test units cut
    before failure, with ``rul_true_final``); call with ``seed=``, ``n_train=``,
    ``n_test=``."""
    return _tables


@pytest.fixture(scope="module")
def rul_tables_module():
    """:func:`rul_tables` for module-scoped fixtures."""
    return _tables
