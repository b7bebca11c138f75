"""A two-process Dask cluster for the scale-out tests (one per test module)."""

from __future__ import annotations

import contextlib
import logging

import pytest


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.CRITICAL,
    )
    c = distributed.Client(cluster, set_as_default=False)
    try:
        yield c
    finally:
        c.close()
        # distributed's close can race with a worker a test killed (KeyError in
        # SpecCluster._update_worker_status for a worker already forgotten)
        with contextlib.suppress(KeyError):
            cluster.close()
