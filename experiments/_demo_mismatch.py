"""The demo's mismatch section: a concealed chamber leak, and the real Cascaded Tanks.

Mismatch discovery is what no other tool does, so the demo shows it twice:

* **a concealed effect in the piston.** Recordings of pdmkit's reduced double-acting
  piston (the ``pneumatic_piston`` showcase model file: position and both chamber
  pressures, a proportional valve) are simulated with an air leak from chamber A to
  ambient that the model file does not have; discovery must name ``leak`` on ``pa``.
  The recordings come from the reduced model itself, not from the full twin of the
  fault ensemble: the twin's 5/2 switching valve, choked orifice flow, end stops and
  dampers make every stroke differ from any reduced model, and a model file as stiff as
  the twin costs minutes per fit, far beyond a two-minute demo;
* **the Cascaded Tanks benchmark** (real recordings, when the data directory is
  present): the Torricelli model without overflow against the estimation / validation
  records, where the known answer is an overflowing upper tank and a lower-tank level
  sensor that saturates at 10 V.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._config import data_dir
from pdmkit._plot_signals import envelope_note
from pdmkit.ensembles import load_dataset
from pdmkit.errors import DataError
from pdmkit.experiments._model_units import output_units

__all__ = ["DemoMismatch", "demo_mismatch_cases"]

#: The concealed effect of the demo and where it hides.
DEMO_CONCEALED = ("leak", "pa")
#: Its strength: relative RMS change of the outputs.
DEMO_STRENGTH = 0.2
#: samples of the concealed piston case (4 s at 200 Hz). At the generator's default 1200
#: the discovery took 200 s (seed 2, 2-core machine); at 800 it takes 19-75 s and names
#: the leak on pa for seeds 0, 1, 2 and 4; seed 3 is `unexplained` at 800 and at 1200
DEMO_SAMPLES = 800


@dataclass
class DemoMismatch:
    """One mismatch-discovery case of the demo.

    Attributes
    ----------
    name : str
        Short title.
    truth : str
        What is known to be missing (the concealed effect, or the published physics).
    right : bool or None
        Whether the verdict names the concealed effect on its target (None for real
        data, whose answer is judged by the reader against ``truth``).
    result : MismatchResult
        The discovery result (``verdict``, ``located``, ``fit``, ``plot``).
    seconds : float
        Wall-clock time of the discovery.
    output : str
        The output its figure shows.
    unit : str, optional
        That output's unit (its figure's axis).
    """

    name: str
    truth: str
    right: bool | None
    result: Any
    seconds: float
    output: str
    unit: str | None = None

    @property
    def named(self) -> str:
        """Every effect of the verdict, ``"leak on pa + sensor_offset on pa"``."""
        v = self.result.verdict
        effects = [
            (v["effect"], v.get("target")),
            *[(a["effect"], a["target"]) for a in v.get("also", [])],
        ]
        return " + ".join(f"{e} on {t}" for e, t in effects)

    def summary(self) -> dict:
        """The case as JSON-ready numbers: verdict, windows, fit before / after.

        Examples
        --------
        >>> from pdmkit.models.mismatch._cases import example_result
        >>> case = DemoMismatch("control", "nothing", True, example_result(), 1.0, "x")
        >>> sorted(case.summary())[:4]
        ['also', 'effect', 'fit', 'located']
        """
        v = self.result.verdict
        fit = self.result.fit
        return {
            "name": self.name,
            "truth": self.truth,
            "effect": v["effect"],
            "target": v.get("target"),
            "physics": v.get("physics"),
            "also": [(a["effect"], a["target"]) for a in v.get("also", [])],
            "named": self.named,
            "right": self.right,
            "fit": {
                "rmse_nominal": float(fit["rmse_nominal"]),
                "rmse_augmented": float(fit["rmse_augmented"]),
            },
            "located": list(self.result.located[:3]),
            "seconds": round(self.seconds, 2),
        }


def _timed_discovery(model, data, validation=None, **options):
    from pdmkit.models.mismatch import discover_mismatch

    start = time.perf_counter()
    result = discover_mismatch(model, data, validation, progress=False, **options)
    return result, time.perf_counter() - start


def concealed_piston_case(seed: int = 0, max_seconds: float | None = None) -> DemoMismatch:
    """Discovery on piston recordings with a concealed chamber-A air leak.

    Parameters
    ----------
    seed : int
        Seed of the excitation, the leak's placement in time and the noise.
    max_seconds : float, optional
        Time budget of the discovery (the best verdict so far is returned).

    Returns
    -------
    DemoMismatch
        ``right`` is True when the verdict names ``leak`` on ``pa``.
    """
    from pdmkit.models.mismatch import generate_concealed_case

    effect, target = DEMO_CONCEALED
    case = generate_concealed_case(
        effect,
        DEMO_STRENGTH,
        seed,
        system="pneumatic_piston",
        target=target,
        n_samples=DEMO_SAMPLES,
    )
    result, seconds = _timed_discovery(case.model, case.data, max_seconds=max_seconds)
    v = result.verdict
    leak = case.params.get("k", float("nan"))
    return DemoMismatch(
        name="piston, concealed chamber-A leak",
        truth=f"leak on pa (k = {leak:.3g}, changes the outputs by "
        f"{100 * case.strength:.0f} % RMS)",
        right=bool(v["effect"] == effect and v.get("target") == target),
        result=result,
        seconds=seconds,
        output=target,
        unit=output_units(case.model).get(target),
    )


#: The real-data case's title (the row the report marks as skipped without it).
TANKS_CASE = "Cascaded Tanks (real recordings)"


def _shown(path: Path) -> str:
    """``path`` as a user would type it from here: relative when that is short."""
    try:
        rel = os.path.relpath(path)
    except ValueError:  # another drive (Windows)
        return str(path)
    return rel if rel.count("..") <= 2 else str(path)


def _tanks_missing(exc: Exception) -> str:
    """Why the Cascaded Tanks records could not be read, in a few words."""
    folder = data_dir("cascaded_tanks")
    if not folder.is_dir():
        return (
            f"{_shown(folder)} not found (set PDMKIT_DATA to the folder that holds "
            "cascaded_tanks)"
        )
    return str(exc).split(";")[0]


def cascaded_tanks_case(max_seconds: float | None = None) -> DemoMismatch | str:
    """Discovery on the real Cascaded Tanks records, or why it could not run.

    Parameters
    ----------
    max_seconds : float, optional
        Time budget of the discovery.

    Returns
    -------
    DemoMismatch or str
        The case; or, when ``$PDMKIT_DATA/cascaded_tanks`` cannot be read, the reason
        (``"../shared/data/cascaded_tanks not found ..."``).
    """
    from pdmkit.models.ode import showcase_model

    try:
        tanks = load_dataset("cascaded-tanks")
    except (DataError, FileNotFoundError, OSError) as exc:
        return _tanks_missing(exc)
    ts = float(tanks["Ts"])

    def frame(u, y):
        u, y = np.asarray(u, float).ravel(), np.asarray(y, float).ravel()
        return pd.DataFrame({"time": np.arange(u.size) * ts, "u": u, "h2": y})

    est = frame(tanks["uEst"], tanks["yEst"])
    val = frame(tanks["uVal"], tanks["yVal"])
    result, seconds = _timed_discovery(
        showcase_model("cascaded_tanks"), est, val, max_seconds=max_seconds
    )
    return DemoMismatch(
        name=TANKS_CASE,
        truth="the upper tank overflows; the lower-tank level sensor saturates at 10 V "
        "(Schoukens et al. 2016)",
        right=None,
        result=result,
        seconds=seconds,
        output="h2",
        unit="V",  # the level sensor's reading (the showcase's h2 is in its volts)
    )


def demo_mismatch_cases(
    seed: int = 0, *, real_data: bool | None = None, max_seconds: float | None = None
) -> tuple[list[DemoMismatch], str | None]:
    """The demo's mismatch cases: the concealed piston leak, and the tanks if present.

    Parameters
    ----------
    seed : int
        Seed of the concealed case.
    real_data : bool, optional
        Run the Cascaded Tanks case (default: when ``$PDMKIT_DATA`` or
        ``../shared/data`` holds it; ``PDMKIT_DEMO_REAL=0`` turns it off).
    max_seconds : float, optional
        Time budget of each discovery.

    Returns
    -------
    cases : list of DemoMismatch
    skipped : str or None
        Why the Cascaded Tanks case did not run (None when it did), for the report.
    """
    cases = [concealed_piston_case(seed, max_seconds)]
    if real_data is None and os.environ.get("PDMKIT_DEMO_REAL", "1") == "0":
        return cases, "PDMKIT_DEMO_REAL=0 turns the real-data case off"
    if real_data is False:
        return cases, "the real-data case was not asked for"
    tanks = cascaded_tanks_case(max_seconds)
    if isinstance(tanks, str):
        return cases, tanks
    return [*cases, tanks], None


def add_mismatch_section(
    report, cases: list[DemoMismatch], number: int, skipped: str | None = None
) -> None:
    """Append the mismatch section (table, text and one figure per case) to ``report``.

    ``skipped`` says why the Cascaded Tanks case is not there (marked in the section).
    """
    report.add_heading(f"{number}. Mismatch discovery: what the model left out")
    report.add_text(
        "pdmkit compares a model file (the physics as written down) with recordings, "
        "locates where they disagree, tries a library of physical effects the model may "
        "have left out (friction, leaks, overflow, dead time, sensor faults, ...), fits "
        "each, and names the one that explains the residual on separate validation data, "
        "or says that none does. Below: an air leak concealed in recordings of the "
        "reduced piston model (generated from the model file itself with the leak added; "
        "the full twin differs from any reduced model at every end stop), and, when the "
        "data directory is present, the real Cascaded Tanks benchmark."
    )
    rows = []
    for c in cases:
        s = c.summary()
        rows.append(
            {
                "case": s["name"],
                "known to be missing": s["truth"],
                "verdict": s["named"],
                "right": "" if s["right"] is None else ("yes" if s["right"] else "no"),
                "RMSE nominal": s["fit"]["rmse_nominal"],
                "RMSE augmented": s["fit"]["rmse_augmented"],
                "seconds": s["seconds"],
            }
        )
    report.add_table(
        pd.DataFrame(rows),
        caption="Verdicts; RMSE on the validation part (re-fitted nominal model -> model "
        "with the named effects), in the output's unit for a model with one output, "
        "each output divided by its scale for several (the piston's x, pa, pb)",
    )
    if skipped:
        report.add_skipped(TANKS_CASE, skipped)
    for c in cases:
        report.add_text(f"{c.name}: {c.result.verdict.get('physics', '')}")
        fig = c.result.plot(output=c.output, unit=c.unit)[0].figure
        note = envelope_note(len(c.result.signals["time"]))
        report.add_figure(
            fig,
            caption=f"{c.name}, {c.output}: measured (black), re-fitted nominal model "
            "(blue), with the named effect (red); residuals below; shaded: the located "
            f"windows. {note}".strip(),
        )
