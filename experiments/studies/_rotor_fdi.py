"""``pdmkit study rotor-fdi``: parametric fault detection and isolation of a rotor.

The rotor-diagnostics monograph

The seed monograph's method, end to end, on the simulated rotor rig
(:class:`pdmkit.models.rigs.RotorRig`, its Tables 11-12):

1. **order selection** (appendix A, sec. 6.5): AIC and MDL over AR orders on a healthy
   record of each bearing channel; the seed found AR(12) adequate for its simulated
   rotor (sec. 4.3.2, Fig. 51; AR(6) under-, AR(16) over-parameterised) and AR(10) for
   its laboratory rig (sec. 4.3.3);
2. **identification**: recursive AR with exponential forgetting on the bearing probes
   (#3, #4) at the seed's 256 Hz (sec. 4.2.1), and **channel-to-channel ARX** parity
   relations ``#2 -> #4`` (the seed's tests T01-T04) and ``#1 -> #3``;
3. **preprocessing**: poles sorted by value against the healthy modes, median then
   Savitzky-Golay filtering with the seed's Table 15 (50; order 2 over 151);
4. **diagnosis**: masks with delay and hysteresis (sec. 3.4, Fig. 32) on five symptoms,
   and the binary diagnostic matrix (sec. 2.8.2) that isolates unbalance,
   misalignment, rub and looseness switching on half-way through a run.

The seed tracks with a circular buffer of 256 samples; pdmkit's recursive estimator
forgets exponentially, so the study runs at the forgetting factors around that buffer:
``(N - 1) / (N + 1) = 0.9922`` (the same estimate variance as a 256-sample window),
``1 - 1 / N = 0.996`` (the same memory), and a half and twice that memory (0.99,
0.998). What makes the isolation hold at every one of them: the masks are tuned on a
healthy record *at the same forgetting factor* (the track noise grows as the memory
shrinks), their alarm delay is one memory ``1 / (1 - lambda)``, every mask's spread has
a floor (a long memory makes healthy tracks so smooth that a mask tuned on them alone
alarms on nothing), the first five memories are start-up, and a run's verdict is the
fault the matrix names for the longest time (at least 3 s).
"""

from __future__ import annotations

import os

from pdmkit._progress import progress
from pdmkit.experiments.studies._rotor_pipeline import (
    FORGETTING_FACTORS,
    ROTOR_MATRIX,
    SYMPTOMS,
    _runs_plan,
    _setup,
    evaluate,
)
from pdmkit.experiments.studies._rotor_report import build_rotor_report, rotor_summary
from pdmkit.experiments.studies._write import write_study
from pdmkit.models.rigs import RotorRig

__all__ = ["FORGETTING_FACTORS", "ROTOR_MATRIX", "SYMPTOMS", "run_rotor_fdi"]


def run_rotor_fdi(
    out_dir: str | os.PathLike,
    *,
    json_path: str | os.PathLike | None = None,
    seed: int = 0,
    quick: bool = False,
) -> dict:
    """Run the rotor FDI study; write ``summary.json`` and ``report.html``.

    Parameters
    ----------
    out_dir : path
        Output folder (:class:`pdmkit._outputs.OutputRun`, command ``study``).
    json_path : path, optional
        Also write the summary here.
    seed : int, default 0
        Seed of the simulated runs (the healthy reference uses ``seed + 100``).
    quick : bool, default False
        30 s runs instead of 60 s, one run per condition, two forgetting factors.

    Returns
    -------
    dict
        The summary: ``isolation`` (share correct per fault and forgetting factor),
        ``false_isolation_healthy``, ``runs``, ``order_selection``, ``rig``,
        ``seed_comparison`` and the timings.

    Examples
    --------
    >>> import tempfile
    >>> s = run_rotor_fdi(tempfile.mkdtemp(), quick=True)  # doctest: +SKIP
    >>> s["all_isolated"]  # doctest: +SKIP
    True
    """

    def compute():
        rig = RotorRig()
        duration = 30.0 if quick else 60.0
        lambdas = (
            (FORGETTING_FACTORS[0], FORGETTING_FACTORS[-1]) if quick else FORGETTING_FACTORS
        )
        # the healthy reference (order selection, parity relations, masks) is 60 s long
        # in every mode; quick shortens the test runs only
        reference = rig.simulate(60.0, seed=seed + 100)
        reference.info["seed"] = seed + 100
        records = []
        for fault, s in progress(_runs_plan(seed, quick), desc="rotor runs"):
            rec = rig.simulate(duration, fault=fault, seed=s)
            rec.info["seed"] = s
            records.append(rec)
        setup = _setup(rig, reference, quick)
        result = evaluate(rig, setup, records, reference, lambdas)
        summary = rotor_summary(rig, setup, result, lambdas, quick, seed)

        def report(written: dict):
            return build_rotor_report(rig, setup, result, records, reference, written)

        return summary, report

    return write_study(out_dir, json_path, compute)
