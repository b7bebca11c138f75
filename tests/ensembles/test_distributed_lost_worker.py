"""A Dask worker killed mid-run: its tasks run again elsewhere, the table is unchanged.

A real ``LocalCluster`` of 2 worker processes (1 thread each, behind nannies that start
a new worker after one dies). The kill comes from inside a task: the first partition to
start SIGKILLs its own worker process, once (a marker file says it happened), so the
worker always dies mid-run with its partition (and the scattered batch of members it
holds) in flight. A task that kills every worker it lands on ends in one
``WorkerLostError`` after a bounded number of deaths.
"""

from __future__ import annotations

import os
import signal
import time
import warnings

import numpy as np
import pandas as pd
import pytest

from pdmkit.ensembles import Ensemble
from pdmkit.ensembles._distributed import LOST_TASK_ATTEMPTS, WorkerLostError, dask_map
from pdmkit.features import extract_ensemble

distributed = pytest.importorskip("distributed")

pytestmark = [pytest.mark.distributed, pytest.mark.slow]


def _kill_own_worker_once(marker: str):
    """A function for ``client.run``: the workers' next partition kills its worker.

    Nested functions travel to the workers by value (the test module is not importable
    there). Only the first partition to start finds no marker: it creates it and kills
    its own worker process. The worker that a nanny starts in its place is not patched.
    """

    def patch():
        import pdmkit.features._plan as extract

        original = extract._batch_table

        def batch_table(*args, **kwargs):
            try:
                fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                return original(*args, **kwargs)
            os.close(fd)
            os.kill(os.getpid(), signal.SIGKILL)

        extract._batch_table = batch_table

    return patch


def _always_kill_worker():
    def die(item):
        os.kill(os.getpid(), signal.SIGKILL)

    return die


@pytest.fixture(scope="module")
def ensemble():
    rng = np.random.default_rng(11)
    t = np.arange(4096) / 2000.0
    tone = np.sin(2 * np.pi * rng.uniform(20, 300, size=(48, 1)) * t)
    return Ensemble(
        {"vib": tone + 0.3 * rng.normal(size=(48, 4096)), "p": rng.normal(size=(48, 512))},
        fs={"vib": 2000.0, "p": 500.0},
        conditions={"fault": np.array(["none", "ir", "or"])[np.arange(48) % 3]},
    )


def _wait_for_workers(c, n=2, timeout=300.0):
    # nannies restart killed workers slowly when the machine is loaded (a CI run beside
    # other work took over 120 s); the tests that kill every worker need only one back
    c.wait_for_workers(n, timeout=timeout)
    deadline = time.monotonic() + timeout
    while len(c.scheduler_info()["workers"]) < n and time.monotonic() < deadline:
        time.sleep(0.1)


def _run_with_one_kill(c, tmp_path, source):
    _wait_for_workers(c)
    marker = tmp_path / "killed"
    c.run(_kill_own_worker_once(str(marker)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = extract_ensemble(source, batch_size=4, client=c)
    assert marker.exists(), "no worker was killed: the test did not test anything"
    # usually the dead worker held the task's scattered input, and the driver says it
    # sends the task again; when the scheduler re-ran the task itself (the input had
    # been copied to the other worker) nothing is said
    for w in caught:
        if issubclass(w.category, RuntimeWarning) and "Dask worker" in str(w.message):
            assert "computed again (attempt 2 of" in str(w.message)
    return table


@pytest.mark.parametrize("on_disk", [False, True], ids=["in-memory", "parquet"])
def test_a_killed_worker_s_partitions_are_recomputed(client, ensemble, tmp_path, on_disk):
    source = (
        ensemble.to_parquet(tmp_path / "ens", members_per_file=5) if on_disk else ensemble
    )
    expected = extract_ensemble(source, batch_size=4)  # in-process, no worker dies
    table = _run_with_one_kill(client, tmp_path, source)
    pd.testing.assert_frame_equal(table, expected, check_exact=True)


def test_a_resumable_run_survives_a_killed_worker(client, ensemble, tmp_path):
    from pdmkit.experiments._runs import extract_features_run

    expected, _ = extract_features_run(ensemble, tmp_path / "local", batch_size=4)
    _wait_for_workers(client)
    marker = tmp_path / "killed"
    client.run(_kill_own_worker_once(str(marker)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        table, errors = extract_features_run(
            ensemble, tmp_path / "remote", batch_size=4, client=client
        )
    assert marker.exists()
    assert len(errors) == 0
    pd.testing.assert_frame_equal(table, expected, check_exact=True)


def test_a_task_that_kills_every_worker_ends_in_one_error(client):
    _wait_for_workers(client, n=1)
    start = time.monotonic()
    with warnings.catch_warnings(), pytest.raises(WorkerLostError) as info:
        warnings.simplefilter("ignore", RuntimeWarning)
        # a dict is scattered: each death loses it and the driver sends it again
        dask_map(_always_kill_worker(), [{"member": "m0"}], client=client)
    message = str(info.value)
    assert "\n" not in message
    assert f"lost {LOST_TASK_ATTEMPTS} times" in message
    assert "smaller batch size" in message
    assert isinstance(info.value, ConnectionError)  # the CLI: one line, exit status 2
    assert time.monotonic() - start < 60
    _wait_for_workers(client, n=1)  # a nanny started a new worker: the cluster works
    assert dask_map(abs, [-1, -2], client=client) == [1, 2]


def test_the_scheduler_giving_up_on_a_task_is_one_error(client):
    _wait_for_workers(client, n=1)
    with warnings.catch_warnings(), pytest.raises(WorkerLostError) as info:
        warnings.simplefilter("ignore", RuntimeWarning)
        # a number is not scattered: the scheduler re-runs the task itself, up to
        # distributed.scheduler.allowed-failures times, then gives up (KilledWorker)
        dask_map(_always_kill_worker(), [7], client=client)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith("task 0 killed every Dask worker that ran it")
    _wait_for_workers(client, n=1)
    assert dask_map(abs, [-3], client=client) == [3]
