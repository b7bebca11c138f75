"""pdmkit.models.rigs: simulated test rigs of the source studies.

:class:`MassBeamRig`: the mass-beam rig of Khatkhate, Ray & Keller 2007 (two masses on a
cantilever beam, modal model with the beam's stiffness from Euler-Bernoulli theory),
used for its resonances (also with the beams' mass distributed: :func:`beam_fe_modes`)
and for the symbolic-dynamics fatigue study (:meth:`MassBeamRig.fatigue_run`,
:class:`FatigueRun`).

:class:`MotorGearboxRig`: the DC motor and four-gear chain of the fractional-calculus
paper (transmission paths from a broken tooth to the motor current and the
output-bearing accelerometer), whose current / accelerometer transfer function changes
with the condition (:data:`MOTOR_CONDITIONS`); :class:`MotorRecord` is one simulated
record.

:class:`RotorRig`: the two-disk rotor of the rotor-diagnostics monograph on a rigid and
a hydrodynamic short bearing (:func:`short_bearing_coefficients`), with unbalance,
misalignment, rub and looseness switching on during a run (:data:`ROTOR_FAULTS`;
:class:`RotorRecord`).

:class:`BallbotRig`: the unstable, under-actuated ball-balancing robot of the S-Mobile
paper (planar S-Mobile) with its known stabilising controller
(:class:`BallbotController`), exact linearisation, closed-loop chirp runs
(:func:`chirp_reference`, :class:`BallbotRecord`).

Examples
--------
>>> from pdmkit.models.rigs import MassBeamRig
>>> type(MassBeamRig()).__name__
'MassBeamRig'
"""

from pdmkit.models.rigs._massbeam import FatigueRun, MassBeamRig, beam_fe_modes
from pdmkit.models.rigs._motor import MOTOR_CONDITIONS, MotorGearboxRig, MotorRecord
from pdmkit.models.rigs._rotor import (
    ROTOR_FAULTS,
    RotorRecord,
    RotorRig,
    short_bearing_coefficients,
)
from pdmkit.models.rigs._unstable import (
    BallbotController,
    BallbotRecord,
    BallbotRig,
    chirp_reference,
)

__all__ = [
    "MOTOR_CONDITIONS",
    "ROTOR_FAULTS",
    "BallbotController",
    "BallbotRecord",
    "BallbotRig",
    "FatigueRun",
    "MassBeamRig",
    "MotorGearboxRig",
    "MotorRecord",
    "RotorRecord",
    "RotorRig",
    "beam_fe_modes",
    "chirp_reference",
    "short_bearing_coefficients",
]
