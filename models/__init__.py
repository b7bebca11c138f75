"""pdmkit.models: dynamic models, one subpackage per concept.

========================  ==============================================================
subpackage                what it holds
========================  ==============================================================
``models.pneumatic``      the pneumatic piston's digital twin (seed ``001``): parameters,
                          right-hand side, batched integrator, sensor models, estimation
``models.ode``            user ODE model files, their batched simulation (plain or with
                          added terms), linearisation, the built-in showcase models
``models.mismatch``       mismatch discovery: fit, locate, candidate physics, sparse
                          terms, verdict
``models.diagnosis``      diagnostic masks and matrices (seed ``000``), symbolic dynamics
                          (seed ``002``)
``models.rigs``           simulated rigs of the source studies (the mass-beam rig)
========================  ==============================================================

System identification (``docs/identification.md``): :func:`identify` dispatches to
:func:`ar`, :func:`arx`, :func:`armax`, :func:`oe`, :func:`bj` (prediction-error
methods) and :func:`n4sid` (subspace), with :func:`select_order` by AIC/BIC/MDL; an
:class:`IdentifiedModel` gives poles, natural frequencies, damping and simulation.
:class:`RecursiveARX` and :func:`track_poles` follow poles over time.

Frequency domain and nonlinear structures (``docs/model_indicators.md``):
:func:`frf_estimate` (H1 with coherence), :func:`fit_tf` (Sanathanan-Koerner rational
fits in s or z), :func:`fit_frf_params` (coherence-weighted grey-box fits),
:func:`balanced_truncation`; :func:`linearize` (Jacobians by autograd);
:class:`HammersteinWiener`; fractional-order models (:func:`fit_fractional_tf`,
:func:`gl_simulate`, :func:`oustaloup`).

The public names of every subpackage are also importable from ``pdmkit.models``
directly.

Examples
--------
>>> from pdmkit.models import PneumaticParams, simulate_piston
>>> r = simulate_piston(PneumaticParams(), t_end=0.5, seed=0)
>>> round(float(r.states["position"][0, -1]), 3)
0.16
"""

from pdmkit.models._fractional import (
    FractionalConditionClassifier,
    FractionalFit,
    FractionalTF,
    fit_fractional_frf,
    fit_fractional_tf,
    gl_simulate,
    gl_weights,
    model_distance,
    oustaloup,
)
from pdmkit.models._frf import (
    FRF,
    AmplitudeDependence,
    GreyBoxFit,
    ReducedModel,
    TFFit,
    amplitude_dependence,
    balanced_truncation,
    fit_frf_params,
    fit_tf,
    frf_estimate,
    hankel_singular_values,
)
from pdmkit.models._hammerstein import (
    DeadZone,
    HammersteinWiener,
    PiecewiseLinear,
    Polynomial,
    Saturation,
    nonlinearity,
)
from pdmkit.models._ident import (
    CRITERIA,
    STRUCTURES,
    IdentifiedModel,
    OrderSelection,
    ar,
    arx,
    fit_percent,
    identify,
    modes_from_poles,
    select_order,
)
from pdmkit.models._ident_pem import armax, bj, oe
from pdmkit.models._recursive import PoleTracks, RecursiveARX, smooth_tracks, track_poles
from pdmkit.models._subspace import n4sid, ss_predict, ss_simulate
from pdmkit.models.diagnosis import (
    DiagnosticMask,
    DiagnosticMatrix,
    MaskResult,
    SymbolicAnomaly,
    max_entropy_partition,
    state_probabilities,
    symbolize,
)
from pdmkit.models.mismatch import (
    CANDIDATE_IDS,
    Candidate,
    ConcealedCase,
    Effect,
    FitResult,
    MismatchResult,
    Recording,
    SparseTerms,
    Term,
    attach_candidates,
    candidate_library,
    discover_mismatch,
    dm_test,
    example_result,
    fit_model,
    generate_concealed_case,
    library_terms,
    make_recording,
    nominal_scales,
    region_statistics,
    residual_spectrum,
    residual_windows,
    score_concealed_cases,
    sparse_equation,
    stlsq_path,
    whiteness_test,
)
from pdmkit.models.ode import (
    KINDS,
    SHOWCASE_NAMES,
    LinearModel,
    OdeModel,
    ResponseData,
    linearize,
    load_model_file,
    load_model_source,
    showcase_model,
    showcase_source,
    simulate_ode,
)
from pdmkit.models.pneumatic import (
    SENSOR_NAMES,
    SENSOR_UNITS,
    STATE_NAMES,
    EstimationResult,
    PneumaticParams,
    PneumaticResponse,
    SensorSpec,
    default_sensor_specs,
    estimate_parameters,
    initial_state,
    orifice_mass_flow,
    outflow_function,
    piston_rhs,
    simulate_piston,
    simulate_piston_ivp,
    stack_params,
    valve_command,
)
from pdmkit.models.rigs import MassBeamRig

__all__ = [
    "CANDIDATE_IDS",
    "CRITERIA",
    "FRF",
    "KINDS",
    "SENSOR_NAMES",
    "SENSOR_UNITS",
    "SHOWCASE_NAMES",
    "STATE_NAMES",
    "STRUCTURES",
    "AmplitudeDependence",
    "Candidate",
    "ConcealedCase",
    "DeadZone",
    "DiagnosticMask",
    "DiagnosticMatrix",
    "Effect",
    "EstimationResult",
    "FitResult",
    "FractionalConditionClassifier",
    "FractionalFit",
    "FractionalTF",
    "GreyBoxFit",
    "HammersteinWiener",
    "IdentifiedModel",
    "LinearModel",
    "MaskResult",
    "MassBeamRig",
    "MismatchResult",
    "OdeModel",
    "OrderSelection",
    "PiecewiseLinear",
    "PneumaticParams",
    "PneumaticResponse",
    "PoleTracks",
    "Polynomial",
    "Recording",
    "RecursiveARX",
    "ReducedModel",
    "ResponseData",
    "Saturation",
    "SensorSpec",
    "SparseTerms",
    "SymbolicAnomaly",
    "TFFit",
    "Term",
    "amplitude_dependence",
    "ar",
    "armax",
    "arx",
    "attach_candidates",
    "balanced_truncation",
    "bj",
    "candidate_library",
    "default_sensor_specs",
    "discover_mismatch",
    "dm_test",
    "estimate_parameters",
    "example_result",
    "fit_fractional_frf",
    "fit_fractional_tf",
    "fit_frf_params",
    "fit_model",
    "fit_percent",
    "fit_tf",
    "frf_estimate",
    "generate_concealed_case",
    "gl_simulate",
    "gl_weights",
    "hankel_singular_values",
    "identify",
    "initial_state",
    "library_terms",
    "linearize",
    "load_model_file",
    "load_model_source",
    "make_recording",
    "max_entropy_partition",
    "model_distance",
    "modes_from_poles",
    "n4sid",
    "nominal_scales",
    "nonlinearity",
    "oe",
    "orifice_mass_flow",
    "oustaloup",
    "outflow_function",
    "piston_rhs",
    "region_statistics",
    "residual_spectrum",
    "residual_windows",
    "score_concealed_cases",
    "select_order",
    "showcase_model",
    "showcase_source",
    "simulate_ode",
    "simulate_piston",
    "simulate_piston_ivp",
    "smooth_tracks",
    "sparse_equation",
    "ss_predict",
    "ss_simulate",
    "stack_params",
    "state_probabilities",
    "stlsq_path",
    "symbolize",
    "track_poles",
    "valve_command",
    "whiteness_test",
]
