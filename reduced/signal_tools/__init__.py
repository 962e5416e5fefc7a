"""Signal tools for acceleration and force records: smoothing, differentiation,
integration, impact-type classification, closure-force detection, resampling and
normalisation of network features.

All records are uniformly sampled 1-D arrays with sampling interval ``dt`` (s);
every setting is an explicit argument or a field of a small frozen class.
"""

from .classification import IMPACT_KINDS, ImpactClassification, classify_impact, zero_frequency_ratio
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
    "IMPACT_KINDS",
    "SCALER_KINDS",
    "SMOOTHERS",
    "AdaptiveBandwidth",
    "AdaptiveFit",
    "ClosureForceEstimate",
    "FeatureScaler",
    "GaussianKernel",
    "ImpactClassification",
    "SavitzkyGolay",
    "Smoother",
    "SpectralLowPass",
    "classify_impact",
    "detect_closure_force",
    "integrate_twice",
    "peak_normalise",
    "resample_record",
    "robust_noise_std",
    "zero_frequency_ratio",
]
