"""pdmkit.models.rigs: simulated test rigs of the source studies.

:class:`MassBeamRig`: the mass-beam rig of seed ``002`` (two masses on a cantilever
beam, modal model with the beam's stiffness from Euler-Bernoulli theory), used for its
resonances and for the symbolic-dynamics fatigue study.

Examples
--------
>>> from pdmkit.models.rigs import MassBeamRig
>>> type(MassBeamRig()).__name__
'MassBeamRig'
"""

from pdmkit.models.rigs._massbeam import MassBeamRig

__all__ = ["MassBeamRig"]
