"""Signal tools for acceleration and force records: smoothing, differentiation,
integration, impact-type classification, closure-force detection, resampling and
normalisation of network features.

All records are uniformly sampled 1-D arrays with sampling interval ``dt`` (s);
every setting is an explicit argument or a field of a small frozen class.
"""

from .classification import (
    CLOSING_SIGMAS,
    IMPACT_KINDS,
    MAX_THRESHOLD,
    NOISE_ENERGY_FACTOR,
    NOT_AN_IMPACT,
    ImpactClassification,
    MomentumEvidence,
    classify_impact,
    momentum_evidence,
    zero_frequency_ratio,
)
from .closure_force import ClosureForceEstimate, detect_closure_force
from .records import SCALER_KINDS, FeatureScaler, peak_normalise, resample_record
from .smoothing import (
    SMOOTHERS,
    AdaptiveBandwidth,
    AdaptiveFit,
    GaussianKernel,
    SavitzkyGolay,
    Smoother,
    SpectralLowPass,
    integrate_twice,
    robust_noise_std,
)

__all__ = [
    "CLOSING_SIGMAS",
    "IMPACT_KINDS",
    "MAX_THRESHOLD",
    "NOISE_ENERGY_FACTOR",
    "NOT_AN_IMPACT",
    "SCALER_KINDS",
    "SMOOTHERS",
    "AdaptiveBandwidth",
    "AdaptiveFit",
    "ClosureForceEstimate",
    "FeatureScaler",
    "GaussianKernel",
    "ImpactClassification",
    "MomentumEvidence",
    "SavitzkyGolay",
    "Smoother",
    "SpectralLowPass",
    "classify_impact",
    "detect_closure_force",
    "integrate_twice",
    "momentum_evidence",
    "peak_normalise",
    "resample_record",
    "robust_noise_std",
    "zero_frequency_ratio",
]
