"""pdmkit.models.diagnosis: from tracked quantities and signals to symptoms and faults.

Diagnostic masks with alarm delay and hysteresis, and the binary diagnostic matrix that
isolates the fault from the symptoms (the rotor-diagnostics monograph, sections 2.8,
3.4: :class:`DiagnosticMask`, :class:`DiagnosticMatrix`); and symbolic dynamics of time
series, the anomaly measure of Khatkhate et al. 2007 (uniform, maximum-entropy and SFNN
partitions, symbol-state probabilities, :class:`SymbolicAnomaly`; Ray 2004, Rajagopalan
& Ray 2006, Kennel & Buhl 2003), and the anomaly measures Khatkhate et al. compare it
with (:class:`PCAAnomaly`, :class:`RBFAnomaly`, :class:`MLPAnomaly`; Chin, Ray &
Rajagopalan 2005). Residual generators of the rotor monograph (sec. 2.4-2.5):
channel-to-channel ARX relations between two measured outputs
(:func:`channel_to_channel`), parity equations on them (:class:`ParityEquations`,
:func:`parity_residual`) and the input reconstructed by an inverted model
(:func:`reconstruct_input`). Condition monitoring in service (issue 31): a health model
fitted on healthy rows only, with PCA T²/Q, robust Mahalanobis, isolation-forest or
symbolic-dynamics scores, a health index, a split-conformal alarm threshold and
persistent alarms (:class:`HealthModel`, :func:`conformal_threshold`,
:func:`persistent_alarm`, :func:`calibration_split`; ``docs/monitoring.md``).

Examples
--------
>>> import numpy as np
>>> from pdmkit.models.diagnosis import DiagnosticMask
>>> mask = DiagnosticMask(lower=0.9, upper=1.1, delay=3)
>>> mask.evaluate(np.r_[np.ones(10), 1.5 * np.ones(10)]).onsets.tolist()
[13]
"""

from pdmkit.models.diagnosis._anomaly import MLPAnomaly, PCAAnomaly, RBFAnomaly
from pdmkit.models.diagnosis._health import HealthModel
from pdmkit.models.diagnosis._health_threshold import (
    alarm_runs,
    calibration_split,
    conformal_threshold,
    persistent_alarm,
)
from pdmkit.models.diagnosis._masks import DiagnosticMask, DiagnosticMatrix, MaskResult
from pdmkit.models.diagnosis._residual_generators import (
    ParityEquations,
    ParityResult,
    channel_to_channel,
    parity_residual,
    reconstruct_input,
)
from pdmkit.models.diagnosis._symbolic import (
    SymbolicAnomaly,
    max_entropy_partition,
    sfnn_fraction,
    sfnn_partition,
    state_probabilities,
    symbolize,
    uniform_partition,
)

__all__ = [
    "DiagnosticMask",
    "DiagnosticMatrix",
    "HealthModel",
    "MLPAnomaly",
    "MaskResult",
    "PCAAnomaly",
    "ParityEquations",
    "ParityResult",
    "RBFAnomaly",
    "SymbolicAnomaly",
    "alarm_runs",
    "calibration_split",
    "channel_to_channel",
    "conformal_threshold",
    "max_entropy_partition",
    "parity_residual",
    "persistent_alarm",
    "reconstruct_input",
    "sfnn_fraction",
    "sfnn_partition",
    "state_probabilities",
    "symbolize",
    "uniform_partition",
]
