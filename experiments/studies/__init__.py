"""The source studies, each run end to end as its paper ran it: ``pdmkit study NAME``.

Each study simulates the rig its source document describes (with the faults and
conditions the document names), runs pdmkit's methods on it the way the document
does, and writes ``summary.json`` and ``report.html`` with the document's published
numbers beside pdmkit's.

=========================  ======================================================
name                       study
=========================  ======================================================
``rotor-fdi``              parametric fault detection and isolation of a rotor
``mass-beam``              symbolic-dynamics fatigue anomaly of the mass-beam rig
``unstable-closed-loop``   closed-loop identification of an unstable system
``motor-fractional``       fractional-order diagnosis of an electric motor
=========================  ======================================================

Examples
--------
>>> from pdmkit.experiments.studies import STUDIES
>>> sorted(STUDIES)
['mass-beam', 'motor-fractional', 'rotor-fdi', 'unstable-closed-loop']
"""

from importlib import import_module as _import_module
from os import PathLike as _PathLike

__all__ = ["STUDIES", "run_study"]

#: study name -> (module in this package, its ``run_*`` function, one-line description)
STUDIES: dict[str, tuple[str, str, str]] = {
    "rotor-fdi": (
        "_rotor_fdi",
        "run_rotor_fdi",
        "parametric fault detection and isolation of a rotor (pole tracking, masks, "
        "diagnostic matrix)",
    ),
    "mass-beam": (
        "_mass_beam",
        "run_mass_beam",
        "fatigue anomaly of the mass-beam rig: symbolic dynamics against PCA, RBF "
        "and MLP anomaly measures",
    ),
    "unstable-closed-loop": (
        "_closed_loop",
        "run_unstable_closed_loop",
        "identification of an unstable plant in closed loop under a known controller",
    ),
    "motor-fractional": (
        "_motor_fractional",
        "run_motor_fractional",
        "fractional-order models of a motor's electrical transfer function for "
        "fault classification",
    ),
}


def run_study(
    name: str,
    out_dir: str | _PathLike,
    *,
    json_path: str | _PathLike | None = None,
    seed: int = 0,
    quick: bool = False,
) -> dict:
    """Run the study ``name``; write ``summary.json`` and ``report.html`` into ``out_dir``.

    Parameters
    ----------
    name : str
        A key of :data:`STUDIES`.
    out_dir : path
        The output folder (written as every pdmkit command writes, see
        :mod:`pdmkit._outputs`).
    json_path : path, optional
        Also write the summary here.
    seed : int, default 0
        Seed of the simulated rig's noise and faults.
    quick : bool, default False
        A smaller run (fewer records, shorter records) for tests and a first look.

    Returns
    -------
    dict
        The study's summary (what ``summary.json`` holds).

    Examples
    --------
    >>> from pdmkit.experiments.studies import run_study
    >>> run_study("rotor", "results/study")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: study: unknown study 'rotor'; expected one of mass-beam, ...
    """
    if name not in STUDIES:
        from pdmkit.errors import DataError

        raise DataError(
            f"study: unknown study {name!r}; expected one of {', '.join(sorted(STUDIES))}"
        )
    module, function, _ = STUDIES[name]
    run = getattr(_import_module(f"{__name__}.{module}"), function)
    return run(out_dir, json_path=json_path, seed=seed, quick=quick)
