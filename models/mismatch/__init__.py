"""pdmkit.models.mismatch: where a simulation and real recordings differ, and why.

A user's model is a plain Python model file (:mod:`pdmkit.models.ode`: the contract of
``docs/model_files.md``, :func:`~pdmkit.models.ode.load_model_file`,
:func:`~pdmkit.models.ode.simulate_ode`). :func:`discover_mismatch` is a short pipeline
of named steps:

1. **fit** the nominal model by simulation error (:func:`fit_model`; long records in
   pieces, oversampled ones decimated, :mod:`._fit`);
2. **locate** the residual in time, state space and frequency
   (:func:`residual_windows`, :func:`region_statistics`, :func:`residual_spectrum`,
   :func:`whiteness_test`, :mod:`._locate`);
3. **screen and refit** the candidate physics of the library
   (:func:`candidate_library`, :class:`Candidate`, :mod:`._candidates`; pass your own
   :class:`Candidate` subclasses the same way), grow companions and pairs;
4. **fall back** to a sparse equation selected through the simulation
   (:func:`sparse_equation`, :mod:`._sparse`);
5. **decide** with significance, parsimony and whiteness (:mod:`._select`), and say
   what was found (:class:`MismatchResult`, :mod:`._verdict`); :mod:`._discover` runs
   the steps.

:func:`generate_concealed_case` and :func:`score_concealed_cases` (:mod:`._cases`) hide
an effect in a known model, for checks.

Examples
--------
>>> from pdmkit.models.mismatch import discover_mismatch, generate_concealed_case
>>> case = generate_concealed_case("sensor_offset", 0.3, seed=0, n_samples=300)
>>> res = discover_mismatch(case.model, case.data, pairs=False,
...                         effects=["sensor_offset", "sensor_gain"])
>>> res.verdict["effect"], res.verdict["target"] == case.target
('sensor_offset', True)
"""

from pdmkit.models._residuals import dm_test, whiteness_test
from pdmkit.models.mismatch._candidates import (
    CANDIDATE_IDS,
    Candidate,
    Effect,
    ParamSpec,
    Scales,
    attach_candidates,
    candidate_library,
)
from pdmkit.models.mismatch._cases import (
    ConcealedCase,
    example_result,
    generate_concealed_case,
    score_concealed_cases,
)
from pdmkit.models.mismatch._discover import MismatchResult, discover_mismatch
from pdmkit.models.mismatch._fit import FitResult, fit_model, nominal_scales
from pdmkit.models.mismatch._locate import (
    region_statistics,
    residual_spectrum,
    residual_windows,
)
from pdmkit.models.mismatch._recording import (
    Recording,
    choose_input_hold,
    join_recordings,
    make_recording,
)
from pdmkit.models.mismatch._reference import ChangeResult, diagnose_change
from pdmkit.models.mismatch._sampling import choose_decimation, choose_pieces, decimate
from pdmkit.models.mismatch._sparse import (
    SparseTerms,
    Term,
    library_terms,
    sparse_equation,
    stlsq_path,
)

__all__ = [
    "CANDIDATE_IDS",
    "Candidate",
    "ChangeResult",
    "ConcealedCase",
    "Effect",
    "FitResult",
    "MismatchResult",
    "ParamSpec",
    "Recording",
    "Scales",
    "SparseTerms",
    "Term",
    "attach_candidates",
    "candidate_library",
    "choose_decimation",
    "choose_input_hold",
    "choose_pieces",
    "decimate",
    "diagnose_change",
    "discover_mismatch",
    "dm_test",
    "example_result",
    "fit_model",
    "generate_concealed_case",
    "join_recordings",
    "library_terms",
    "make_recording",
    "nominal_scales",
    "region_statistics",
    "residual_spectrum",
    "residual_windows",
    "score_concealed_cases",
    "sparse_equation",
    "stlsq_path",
    "whiteness_test",
]
