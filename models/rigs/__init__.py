"""pdmkit.models.rigs: simulated test rigs of the source studies.

:class:`MassBeamRig`: the mass-beam rig of seed ``002`` (two masses on a cantilever
beam, modal model with the beam's stiffness from Euler-Bernoulli theory), used for its
resonances (also with the beams' mass distributed: :func:`beam_fe_modes`) and for the
symbolic-dynamics fatigue study (:meth:`MassBeamRig.fatigue_run`, :class:`FatigueRun`).

:class:`MotorGearboxRig`: the DC motor and four-gear chain of seed ``004`` (transmission
paths from a broken tooth to the motor current and the output-bearing accelerometer),
whose current / accelerometer transfer function changes with the condition
(:data:`MOTOR_CONDITIONS`); :class:`MotorRecord` is one simulated record.


Examples
--------
>>> from pdmkit.models.rigs import MassBeamRig
>>> type(MassBeamRig()).__name__
'MassBeamRig'
"""

from pdmkit.models.rigs._massbeam import FatigueRun, MassBeamRig, beam_fe_modes
from pdmkit.models.rigs._motor import MOTOR_CONDITIONS, MotorGearboxRig, MotorRecord

__all__ = [
    "MOTOR_CONDITIONS",
    "FatigueRun",
    "MassBeamRig",
    "MotorGearboxRig",
    "MotorRecord",
    "beam_fe_modes",
]
