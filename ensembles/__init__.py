"""pdmkit.ensembles: recordings and their condition variables.

An :class:`Ensemble` holds members (recordings): named 1-D signals, each with its
sampling rate, and a row of condition variables (labels, settings, operating point,
unit, cycle). It is stored on disk as a Parquet dataset that streams in batches
(:meth:`Ensemble.to_parquet`, :func:`iter_parquet`). Readers turn the file formats
recordings come in into arrays and tables; loaders bring the shared recorded datasets;
simulators generate labelled ensembles from the pneumatic-piston digital twin.
On a Dask cluster (:func:`dask_client`), :func:`dask_map` and :func:`dask_stream` run the
same per-partition work as in process (:func:`parquet_partitions`, :func:`simulate_sweep`,
:func:`discover_mismatch_batch`); see ``docs/scale.md``.

Examples
--------
>>> import numpy as np
>>> import pdmkit.ensembles as pe
>>> ens = pe.Ensemble({"vib": np.zeros((2, 4096))}, fs=4096.0,
...                   conditions={"fault": ["none", "inner_race"]})
>>> ens.frames(1024).conditions["fault"].value_counts().to_dict()
{'none': 4, 'inner_race': 4}
"""

from pdmkit.ensembles._datasets import (
    BATTERY_EOL_AH,
    DATASETS,
    load_cascaded_tanks,
    load_cmapss,
    load_cwru,
    load_dataset,
    load_emps,
    load_nasa_battery,
    load_silverbox,
)
from pdmkit.ensembles._distributed import (
    Partition,
    dask_client,
    dask_map,
    dask_stream,
    discover_mismatch_batch,
    parquet_partitions,
    read_partition,
    simulate_sweep,
)
from pdmkit.ensembles._ensemble import Ensemble
from pdmkit.ensembles._matlab_numpy import read_mat, read_npz
from pdmkit.ensembles._member_files import read_members
from pdmkit.ensembles._parquet import url_filesystem, write_parquet_batches
from pdmkit.ensembles._parquet_read import iter_parquet
from pdmkit.ensembles._pneumatic import (
    SEED_JITTER,
    SEED_LABELS,
    SEED_SINGLE_FAULTS,
    SEED_SUPPLY_BAR,
    pneumatic_residuals,
    seed_labels,
    simulate_seed_ensemble,
    simulate_seed_single_fault_ensemble,
)
from pdmkit.ensembles._pneumatic_faults import (
    PNEUMATIC_FAULTS,
    PNEUMATIC_SENSORS,
    fault_labels,
    simulate_fault_ensemble,
    simulate_sensor_fault_ensemble,
)
from pdmkit.ensembles._pneumatic_leak import simulate_leak_runs
from pdmkit.ensembles._table_files import read_table
from pdmkit.ensembles._tables import from_frame

__all__ = [
    "BATTERY_EOL_AH",
    "DATASETS",
    "PNEUMATIC_FAULTS",
    "PNEUMATIC_SENSORS",
    "SEED_JITTER",
    "SEED_LABELS",
    "SEED_SINGLE_FAULTS",
    "SEED_SUPPLY_BAR",
    "Ensemble",
    "Partition",
    "dask_client",
    "dask_map",
    "dask_stream",
    "discover_mismatch_batch",
    "fault_labels",
    "from_frame",
    "iter_parquet",
    "load_cascaded_tanks",
    "load_cmapss",
    "load_cwru",
    "load_dataset",
    "load_emps",
    "load_nasa_battery",
    "load_silverbox",
    "parquet_partitions",
    "pneumatic_residuals",
    "read_mat",
    "read_members",
    "read_npz",
    "read_partition",
    "read_table",
    "seed_labels",
    "simulate_fault_ensemble",
    "simulate_leak_runs",
    "simulate_seed_ensemble",
    "simulate_seed_single_fault_ensemble",
    "simulate_sensor_fault_ensemble",
    "simulate_sweep",
    "url_filesystem",
    "write_parquet_batches",
]
