"""Joint input-state estimation of the coupler force between two cars from car-body accelerations.

Model (continuous time; Lourens et al., MSSP 2012). Each car ``c`` (``rear`` = hammer,
``front`` = anvil) is linear in its own coordinates ``q_c`` (n_c DOFs)::

    M_c q̈_c + C_c q̇_c + K_c q_c = B_c L_c,   L_c = b_c P,   a_c = O_c q̈_c

``L_c`` are the car's end loads (a rod: ``(F1, F2)``, internal axial forces at −l and +l,
tension positive), ``P`` the coupler force (compression positive): ``b_rear = (0, −1)``,
``b_front = (−1, 0)``; ``a_c`` the accelerometer outputs (``O_c`` is S_c × n_c). Through the
equation of motion the outputs feed ``P`` through directly::

    a_c = O_c M_c⁻¹ (B_c b_c P − C_c q̇_c − K_c q_c)

``P`` is a random walk, ``Ṗ = w``, ``E[w(t) w(s)] = q_P δ(t − s)`` (force-rate intensity,
N²/s); each channel carries white noise of declared std ``σ_i`` (m/s²).

The derivation goes on in the modules, in the order of the data flow: :mod:`.cars` (the cars as
declared), :mod:`.augmented` (the filter's model), :mod:`.linear_gaussian` (generic machinery),
:mod:`.steady` (the O(dim²)-per-step estimator), :mod:`.estimate` (:func:`estimate_force`) and
:mod:`.variants` (the band over perturbed models).
"""

from .augmented import AugmentedModel, augmented_model, forced_response, undetectable_couplers
from .cars import CarDynamics, ConsistCars, CoupledCars, SensorFilter
from .estimate import DEFAULT_FORCE_RATE_RANGE, NOISE_SCALES, KalmanForce, estimate_force, estimate_forces, smoothed_responses
from .linear_gaussian import GaussianSmoothing, kalman_smoother, van_loan_discretisation
from .variants import VariantForceEstimate, car_mass_models, corner_models, estimate_force_with_variants, estimate_forces_with_variants

__all__ = [
    "DEFAULT_FORCE_RATE_RANGE",
    "AugmentedModel",
    "CarDynamics",
    "ConsistCars",
    "CoupledCars",
    "KalmanForce",
    "GaussianSmoothing",
    "NOISE_SCALES",
    "VariantForceEstimate",
    "SensorFilter",
    "augmented_model",
    "car_mass_models",
    "corner_models",
    "estimate_force",
    "estimate_forces",
    "estimate_force_with_variants",
    "estimate_forces_with_variants",
    "forced_response",
    "kalman_smoother",
    "smoothed_responses",
    "undetectable_couplers",
    "van_loan_discretisation",
]
