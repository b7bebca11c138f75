"""``pdmkit study unstable-closed-loop``: an unstable plant identified in closed loop.

The S-Mobile identification paper end to end on pdmkit's planar ballbot
(:class:`pdmkit.models.rigs.BallbotRig`), against the open-loop truth, the plant's exact
linearisation:

1. the drive's lag identified alone from a frequency-response measurement (sec. 3.5:
   "the transfer function of the actuator should first be identified separately");
2. the stabilised robot excited through its tilt set-point with chirps of 1.5 to 5
   degrees (sec. 5), recorded at the 100 Hz of its CAN bus;
3. amplitude-dependent closed-loop FRFs ``theta / theta_set`` with coherence >= 0.7
   masks (sec. 3.6, Fig. 4);
4. the plant identified three ways (direct; indirect with the known controller removed,
   secs. 3.3-3.5; joint input-output), its unstable pole and FRF against the truth;
5. the seed's approach (secs. 3.5-3.6, 5): the linearised model's mass moment of inertia
   ``theta_x`` fitted to the measured closed-loop FRF by the coherence-weighted
   Nelder-Mead simplex, with the model linearised at rest and at the seed's angular
   velocity at the zero crossing (eq. 11); the seed reports ``theta_x = 20.31``,
   confirmed by its design data, which is the rig's design value here;
6. real data: EMPS (a positioning system measured in closed loop with a known
   controller; published mass and viscous friction) and the F-16 ground vibration test
   at two excitation levels (amplitude-dependent FRFs), when ``PDMKIT_DATA`` holds them.
"""

from __future__ import annotations

import os

from pdmkit.experiments.studies._closed_loop_checks import emps_check, f16_check
from pdmkit.experiments.studies._closed_loop_pipeline import (
    AMPLITUDES_DEG,
    SEED_THETA_X,
    _study,
    seed_error,
)
from pdmkit.experiments.studies._closed_loop_report import (
    build_closed_loop_report,
    closed_loop_summary,
)
from pdmkit.experiments.studies._write import write_study

__all__ = ["AMPLITUDES_DEG", "SEED_THETA_X", "run_unstable_closed_loop", "seed_error"]


def run_unstable_closed_loop(
    out_dir: str | os.PathLike,
    *,
    json_path: str | os.PathLike | None = None,
    seed: int = 0,
    quick: bool = False,
) -> dict:
    """Run the closed-loop identification study; write ``summary.json`` and ``report.html``.

    Parameters
    ----------
    out_dir : path
        Output folder (:class:`pdmkit._outputs.OutputRun`, command ``study``).
    json_path : path, optional
        Also write the summary here.
    seed : int, default 0
        Seed of the sensor noise and floor torque.
    quick : bool, default False
        Two amplitudes (1.5 and 5 degrees) and three chirp periods instead of four
        amplitudes and five periods.

    Returns
    -------
    dict
        The summary: ``truth``, ``actuator``, ``frf`` (coherence edges, amplitude
        dependence), ``methods`` (unstable pole and FRF error of direct, indirect and
        joint identification per amplitude), ``linear_control``, ``seed_approach``
        (``theta_x`` per amplitude and linearisation), ``real_data`` and
        ``seed_comparison``.

    Examples
    --------
    >>> import tempfile
    >>> s = run_unstable_closed_loop(tempfile.mkdtemp(), quick=True)  # doctest: +SKIP
    >>> round(s["truth"]["unstable_pole"], 2)  # doctest: +SKIP
    7.39
    """

    def compute():
        result = _study(seed, quick)
        result["real_data"] = {"emps": emps_check(), "f16": f16_check()}
        summary = closed_loop_summary(result, quick, seed)
        return summary, lambda written: build_closed_loop_report(result, written)

    return write_study(out_dir, json_path, compute)
