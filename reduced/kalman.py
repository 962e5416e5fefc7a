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

Rigid-body motion and drift (Naets, Cuadrado & Desmet, MSSP 2015). Write ``q = Φ_r r + Φ_e e``
with the mass-normalised modes of ``(K, M)``: ``Φ_r`` spans the null space of ``K`` (rigid
motion), ``Λ_e = diag(ω_j²)``. Internal forces do no work on rigid motion, ``K Φ_r = 0`` and
``C Φ_r = 0`` (checked; a model that breaks it is refused), so::

    r̈ = Φ_rᵀ B b P,   ë + C_ee ė + Λ_e e = Φ_eᵀ B b P,   a = O M⁻¹ B b P − O Φ_e (Λ_e e + C_ee ė)

The rigid displacement ``r`` *and velocity* ``ṙ`` enter no output and no other state's
equation: they are unobservable and exactly disconnected from everything observable. Kept
in the filter their covariance only grows (a constant velocity or position offset is
invisible to accelerometers) and contributes nothing, so they are removed — exactly, not
as an approximation. The filter state is::

    z = [e_rear, ė_rear, e_front, ė_front, P]

and the car speeds (``v0 ± σ_v``) do not enter: no prior on ``ṙ`` can inform ``P`` since
``ṙ`` never reaches an output (if wanted, ``ṙ(t) = ṙ(0) + Φ_rᵀ B b ∫₀ᵗ P``). What remains is
observable, so no dummy measurement is needed: the quasi-static part of ``P`` — which an
acceleration-only filter on a *grounded* structure cannot see (a static load only deforms
it, ``a = 0``; Naets' remedy is a dummy zero-displacement measurement) — is seen here
directly as the rigid-body acceleration, ``M a_rigid = ±P``, of a free car. A dummy
"elastic displacement = 0" measurement would be wrong here: the deformation *responds* to
``P`` (quasi-statically ``e = Λ_e⁻¹ Φ_eᵀ B b P``), so it would pull the force towards zero.
The premise is checked on every model by the PBH test on the marginal eigenvalues of the
augmented system, ``rank [λI − A; H] = dim z`` for ``Re λ ≥ 0`` (detectability); a model that
fails it (e.g. grounded cars) gets the status "force not detectable ...". The tests show a
flat, bounded force estimate over a 5 s quiet tail after the impact.

Recorders' anti-alias filter (:class:`SensorFilter`, ``CoupledCars.sensor_filter``): a channel
that passes an analogue low-pass before it is sampled is modelled as such — the filter's
states ``w`` join the state (before ``P``), driven by the channel's acceleration, and the
sample is the filter's output, ``ẇ = A_f w + b_f (H z)``, ``y = c_f w + v`` (no feed-through
left). Ignoring a 100 Hz 4th-order filter delays the force by its group delay (≈ 4 ms) and
misshapes it (9 % RMS of the peak in the tests); modelled, the force is on time (0.14 %).

Discretisation at the record's step ``h``, exact for the random-walk state (a zero-order
hold on ``P`` is not: ``P`` varies inside the step). With ``ż = A z + G w``, ``G = e_P``
(Van Loan 1978)::

    expm([[−A, G q_P Gᵀ], [0, Aᵀ]] h) = [[·, E12], [0, E22]],
    F = E22ᵀ = e^{Ah},   Q = F E12 = ∫₀ʰ e^{Aτ} G q_P Gᵀ e^{Aᵀτ} dτ

``Q`` is linear in ``q_P``: computed once for ``q_P = 1`` and scaled. Samples:
``y_k = H z_k + v_k``, ``v_k ~ N(0, R)``, ``R = diag(σ_i²)``. Internally the outputs are
whitened (``R = I``) and the states scaled so that one unit of each is about one noise
std on the sensors (conditioning).

Filter and smoother. The reference (:func:`kalman_smoother`) is the textbook recursion::

    ν_k = y_k − H z⁻_k,   S_k = H P⁻_k Hᵀ + R,   K_k = P⁻_k Hᵀ S_k⁻¹
    z⁺_k = z⁻_k + K_k ν_k,  P⁺_k = (I − K_k H) P⁻_k (I − K_k H)ᵀ + K_k R K_kᵀ   (Joseph form)
    z⁻_{k+1} = F z⁺_k,      P⁻_{k+1} = F P⁺_k Fᵀ + Q                             (symmetrised)

with the Rauch–Tung–Striebel posterior in its Bryson–Frazier/de Jong form (no inverse of
``P⁻``, which is nearly singular for an undeformed start)::

    r_{k−1} = Hᵀ S_k⁻¹ ν_k + L_kᵀ r_k,   N_{k−1} = Hᵀ S_k⁻¹ H + L_kᵀ N_k L_k,   L_k = F (I − K_k H)
    ẑ_k = z⁻_k + P⁻_k r_{k−1},            V_k = P⁻_k − P⁻_k N_{k−1} P⁻_k,       r_{N−1} = N_{N−1} = 0

It costs O(dim³) per step. The force estimator uses the same posterior at O(dim²) per step,
exactly, by choosing the prior so that no transient remains: ``z_0 ~ N(0, P∞ + σ_0² u uᵀ)``
with ``P∞`` the stationary predicted covariance (the DARE solution, by the structure-
preserving doubling algorithm, batched over ``q_P``), ``u`` the quasi-static state of a unit
force (``e = Λ_e⁻¹ Φ_eᵀ B b``, ``ė = 0``, ``P = 1``) and ``σ_0`` the declared initial force std:
"the cars are undeformed up to what the sensors resolve in steady state, and carry an
unknown initial force in quasi-static equilibrium" (a coupler preload, or a record that
starts mid-impact). Then ``z_0 = u α + ε``, ``α ~ N(0, σ_0²)``, ``ε ~ N(0, P∞)``, and (de Jong's
augmented filter, 1991) the steady filter — gain ``K∞``, ``L = F (I − K∞ H)`` — gives
innovations ``ν∞_k = h_k α + e_k``, ``h_k = H L^k u``, ``e_k ~ N(0, S∞)`` white. So::

    ℓ = −½ [N log det S∞ + Σ ν∞ᵀ S∞⁻¹ ν∞ + log(1 + σ_0² o) − s²/(σ_0⁻² + o)] − ½ N (m log 2π + log det R)
    s = Σ h_kᵀ S∞⁻¹ ν∞_k,   o = Σ h_kᵀ S∞⁻¹ h_k,   α | y ~ N(s/(σ_0⁻² + o), 1/(σ_0⁻² + o))
    ẑ_k = ẑ∞_k + E[α|y] ψ_k,   V_k = V∞_k + Var[α|y] ψ_k ψ_kᵀ

(``ẑ∞``, ``V∞``: the stationary smoother given α = 0; ``ψ_k`` the smoothed response to a unit
α: the same smoother run with prior mean ``u`` and zero data; ``V∞_k,PP = P∞_PP − Σ_{j<N−k}
|S∞^{-1/2} H L^j P∞ e_P|²``). The tests show this equals the Joseph-form time-varying
filter and smoother with the same prior to ≤ 1e-9. Models that fail the detectability
check have no stationary covariance; they fall back to the reference recursion with the
prior ``N(0, σ_0² u uᵀ)``.

Force-rate level: the innovation log-likelihood ℓ(q_P) above is maximised over a log grid
(default 1e8 … 1e18 N²/s, 15 points, one batched pass) and refined by two rounds of a
three-times finer grid around the best point and a parabolic step (the golden-section/
parabolic idea of Brent, batched: four batched passes in all). An optimum on the coarse
grid's edge is flagged (``at_edge``): the estimate is then not trusted. Consistency:
``NIS = (1/(N m)) Σ ν_kᵀ S_k⁻¹ ν_k`` is ≈ 1 when the declared noise and the model are right;
outside ``nis_range`` the status says so.

Noise scale (``noise_scale="estimated"``): all covariances ``R``, ``Q``, ``P_0`` times a common
``λ`` leaves the gains, the innovations and the smoothed mean unchanged and scales every
``S_k`` by ``λ``, so ``ℓ`` is maximised over λ in closed form, ``λ̂ = NIS`` (Harvey 1989, §3.4),
and the likelihood concentrated over it, ``ℓ_c = −½ (N m log λ̂ + Σ log det S̃_k + N m)``,
is maximised over ``q_P/λ`` as above; the smoothed variances are multiplied by ``λ̂``. With
the declared noise right, ``λ̂ ≈ 1`` and nothing changes. It matters under model error:
a wrong model leaves vibration it cannot explain, and with the sensors' own noise
(≈ 0.05 m/s²) the likelihood explains it by the force — ``q_P`` runs to the top of the range
and the peak is biased up (tests: +18 % and +25 % for cars whose mass, frequencies and
damping differ by +5/−15 %/×1.5 and −2/+7 %/×0.8, flagged by NIS ≈ 180 and 70). With the
scale estimated the misfit shows as noise (×22) instead: +1.6 % and +1.1 %, although the
band then still misses the truth (model error is not white).

Peak: the maximum of the smoothed mean (compression positive) and the pointwise 95 % band
``mean ± 1.96 std`` at that sample. This ignores the uncertainty of *where* the peak is;
it is a fair band for the peak when the std is small against the change of the force
over the few samples around the peak, as for impact pulses at the noise levels of
car-body accelerometers (tests: it covers the true peak in 19–20 of 20 seeds); otherwise
it is slightly optimistic (the maximum of a noisy curve is biased up).

Model uncertainty (:func:`estimate_force_with_variants`): the caller builds perturbed
models (e.g. the corners of mass ±5 %, modal frequencies ±15 %, damping ×0.6–1.6); each is
estimated with its own ``q_P`` and — by default — its own noise scale, and the band is the
union (envelope) of their 95 % bands. The noise scale is needed: with the declared noise
every wrong model biases the peak *up* (see above), so the corners do not bracket a truth
inside the box (tests: +0.4 … +65 % for the interior truth above); with it they do
(−8 … +6 %, and −10 … +14 % for the corner truth). Not ``mean ± 1.96 √(std² + spread²)``:
the variants are extremes chosen by the caller, not draws from a known distribution, so
their sample spread has no probabilistic meaning (a few corners overstate it,
one-at-a-time perturbations understate it, and a handful of models makes a mixture far
from Gaussian); the envelope claims only what it shows — the estimate of every model
considered, each with its noise band. It is a heuristic: the estimate is not monotone in
the parameters, so it brackets the truth only as far as the corners span the estimates of
the models inside the box (as in the tests). No likelihood weighting either: with
thousands of samples the likelihood picks one variant with near certainty even when none
is right. The data do discriminate frequencies and damping (variants near the truth's
have λ̂ ≈ 1.4, the others up to ≈ 560), so calibrating those would narrow the band (not
done here); the mass they cannot: scaling every mass and the force by the same factor
leaves all accelerations unchanged (``a = P/M`` rigidly, and the mass-normalised modes
scale by ``1/√s``), so a mass error passes one to one into the force.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import eigh, expm

from reduced import _checks

RIGID_TOLERANCE = 1e-9  # ω² ≤ this × max ω² counts as a rigid-body mode
DEFAULT_FORCE_RATE_RANGE: tuple[float, float] = (1.0e8, 1.0e18)  # N²/s
Z95 = 1.959963984540054  # two-sided 95 % normal quantile

FloatArray = NDArray[np.float64]


def _swap(a: FloatArray) -> FloatArray:
    return np.swapaxes(a, -1, -2)


def _sym(a: FloatArray) -> FloatArray:
    return 0.5 * (a + _swap(a))


# --------------------------------------------------------------------------------------
# generic linear-Gaussian machinery
# --------------------------------------------------------------------------------------


def van_loan_discretisation(
    system_matrix: ArrayLike, noise_input: ArrayLike, noise_intensity: ArrayLike, step: float
) -> tuple[FloatArray, FloatArray]:
    """``(F, Q)`` of ``ż = A z + G w``, ``E[w(t) w(s)ᵀ] = Q_c δ(t − s)``, sampled exactly at step ``h``.

    ``expm([[−A, G Q_c Gᵀ], [0, Aᵀ]] h) = [[·, E12], [0, E22]]``; ``F = E22ᵀ = e^{Ah}``,
    ``Q = F E12 = ∫₀ʰ e^{Aτ} G Q_c Gᵀ e^{Aᵀτ} dτ`` (Van Loan 1978), symmetrised.
    ``noise_input`` is n × p (a 1-D array is one column), ``noise_intensity`` p × p (a
    scalar for p = 1).
    """
    a = np.atleast_2d(np.asarray(system_matrix, dtype=float))
    n = a.shape[0]
    if a.shape != (n, n) or not np.all(np.isfinite(a)):
        raise ValueError(f"system_matrix must be a finite square matrix, got shape {a.shape}")
    g = np.asarray(noise_input, dtype=float)
    g = g.reshape(n, -1) if g.ndim <= 1 else g
    qc = np.atleast_2d(np.asarray(noise_intensity, dtype=float))
    if g.shape[0] != n or qc.shape != (g.shape[1], g.shape[1]):
        raise ValueError(f"noise_input must be {n} × p and noise_intensity p × p; got {g.shape} and {qc.shape}")
    if not (np.all(np.isfinite(g)) and np.all(np.isfinite(qc))):
        raise ValueError("noise_input and noise_intensity must be finite")
    h = _checks.sample_step("step", step)
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n] = -a
    block[:n, n:] = g @ qc @ g.T
    block[n:, n:] = a.T
    e = expm(block * h)
    transition = np.ascontiguousarray(e[n:, n:].T)
    return transition, _sym(transition @ e[:n, n:])


@dataclass(frozen=True, eq=False)
class GaussianSmoothing:
    """Filter and smoother output of :func:`kalman_smoother` (N steps, n states, m outputs).

    ``predicted_*`` are ``z⁻_k``, ``P⁻_k`` (given y_0 … y_{k−1}), ``filtered_*`` ``z⁺_k``,
    ``P⁺_k`` (given y_0 … y_k), ``smoothed_*`` given all N samples; ``gain`` is ``K_k``
    (n × m), ``innovation`` ``ν_k``; ``log_likelihood`` ``−½ Σ (m log 2π + log det S_k +
    ν_kᵀ S_k⁻¹ ν_k)``; ``nis`` the mean of ``ν_kᵀ S_k⁻¹ ν_k / m``.
    """

    predicted_mean: FloatArray
    predicted_covariance: FloatArray
    filtered_mean: FloatArray
    filtered_covariance: FloatArray
    smoothed_mean: FloatArray
    smoothed_covariance: FloatArray
    gain: FloatArray
    innovation: FloatArray
    log_likelihood: float
    nis: float


def _joseph_smoother(
    transition: FloatArray,
    process: FloatArray,
    observation: FloatArray,
    measurements: FloatArray,
    initial_mean: FloatArray,
    initial_covariance: FloatArray,
) -> tuple[FloatArray, ...]:
    """Reference filter + smoother on whitened outputs (R = I); module docstring, first display.

    Returns ``(z⁻, P⁻, z⁺, P⁺, ẑ, V, K, ν, log det S, ν S⁻¹ ν)`` per step (whitened ``K``, ``ν``, ``S``).
    """
    f, q, hm, y = transition, process, observation, measurements
    steps, m = y.shape
    n = f.shape[0]
    eye_n, eye_m = np.eye(n), np.eye(m)
    xp, pp = np.empty((steps, n)), np.empty((steps, n, n))
    xf, pf = np.empty((steps, n)), np.empty((steps, n, n))
    gains, nus = np.empty((steps, n, m)), np.empty((steps, m))
    s_inv_all, logdet, quad = np.empty((steps, m, m)), np.empty(steps), np.empty(steps)
    x, p = initial_mean.copy(), _sym(initial_covariance)
    for k in range(steps):
        xp[k], pp[k] = x, p
        pht = p @ hm.T
        s = hm @ pht + eye_m
        s_inv = _sym(np.linalg.inv(s))
        gain = pht @ s_inv
        nu = y[k] - hm @ x
        gains[k], nus[k], s_inv_all[k] = gain, nu, s_inv
        logdet[k] = np.linalg.slogdet(s)[1]
        quad[k] = nu @ s_inv @ nu
        a = eye_n - gain @ hm
        xf[k] = x + gain @ nu
        pf[k] = _sym(a @ p @ a.T + gain @ gain.T)
        x, p = f @ xf[k], _sym(f @ pf[k] @ f.T + q)
    r, info = np.zeros(n), np.zeros((n, n))
    xs, vs = np.empty((steps, n)), np.empty((steps, n, n))
    for k in range(steps - 1, -1, -1):
        ell = f @ (eye_n - gains[k] @ hm)
        weighted = hm.T @ s_inv_all[k]
        r = weighted @ nus[k] + ell.T @ r
        info = _sym(weighted @ hm + ell.T @ info @ ell)
        xs[k] = xp[k] + pp[k] @ r
        vs[k] = _sym(pp[k] - pp[k] @ info @ pp[k])
    return xp, pp, xf, pf, xs, vs, gains, nus, logdet, quad


def _whitening(noise_covariance: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """``(W, L, log det R)`` with ``R = L Lᵀ``, ``W = L⁻¹``."""
    try:
        chol = np.linalg.cholesky(noise_covariance)
    except np.linalg.LinAlgError:
        raise ValueError("noise_covariance must be symmetric positive definite") from None
    return np.linalg.inv(chol), chol, 2.0 * float(np.sum(np.log(np.diag(chol))))


def kalman_smoother(
    transition: ArrayLike,
    process_covariance: ArrayLike,
    observation: ArrayLike,
    noise_covariance: ArrayLike,
    initial_mean: ArrayLike,
    initial_covariance: ArrayLike,
    measurements: ArrayLike,
) -> GaussianSmoothing:
    """Kalman filter and RTS smoother of ``z_{k+1} = F z_k + w_k``, ``y_k = H z_k + v_k``.

    ``w_k ~ N(0, Q)``, ``v_k ~ N(0, R)``, ``z_0 ~ N(m_0, P_0)``; ``measurements`` is N × m (or
    N for m = 1). The time-varying recursion with the Joseph-form update and de Jong's form
    of the RTS smoother (module docstring), O(n³) per step, all covariances returned.
    """
    f = np.atleast_2d(np.asarray(transition, dtype=float))
    n = f.shape[0]
    q = np.atleast_2d(np.asarray(process_covariance, dtype=float))
    hm = np.atleast_2d(np.asarray(observation, dtype=float))
    r = np.atleast_2d(np.asarray(noise_covariance, dtype=float))
    y = np.asarray(measurements, dtype=float)
    y = y.reshape(-1, 1) if y.ndim == 1 else y
    m = hm.shape[0]
    x0 = np.asarray(initial_mean, dtype=float).reshape(-1)
    p0 = np.atleast_2d(np.asarray(initial_covariance, dtype=float))
    if (
        f.shape != (n, n)
        or q.shape != (n, n)
        or hm.shape != (m, n)
        or r.shape != (m, m)
        or x0.shape != (n,)
        or p0.shape != (n, n)
        or y.ndim != 2
        or y.shape[1] != m
        or y.shape[0] < 1
    ):
        raise ValueError(f"inconsistent shapes: F {f.shape}, Q {q.shape}, H {hm.shape}, R {r.shape}, m0 {x0.shape}, P0 {p0.shape}, y {y.shape}")
    for name, arr in (("transition", f), ("process_covariance", q), ("observation", hm), ("noise_covariance", r), ("initial_mean", x0), ("initial_covariance", p0), ("measurements", y)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains non-finite values")
    w, chol, logdet_r = _whitening(r)
    xp, pp, xf, pf, xs, vs, gains, nus, logdet, quad = _joseph_smoother(f, q, w @ hm, y @ w.T, x0, p0)
    steps = y.shape[0]
    ell = -0.5 * (float(np.sum(logdet + quad)) + steps * (m * math.log(2.0 * math.pi) + logdet_r))
    return GaussianSmoothing(
        predicted_mean=xp,
        predicted_covariance=pp,
        filtered_mean=xf,
        filtered_covariance=pf,
        smoothed_mean=xs,
        smoothed_covariance=vs,
        gain=gains @ w,
        innovation=nus @ chol.T,
        log_likelihood=ell,
        nis=float(np.sum(quad)) / (steps * m),
    )


def _stationary_covariance(transition: FloatArray, process: FloatArray, observation: FloatArray) -> FloatArray:
    """Stabilising solutions ``P∞`` of ``P = F P Fᵀ − F P Hᵀ (H P Hᵀ + I)⁻¹ H P Fᵀ + Q``, batched over Q.

    Structure-preserving doubling (Chu, Fan & Lin 2005) for ``X = Aᵀ X (I + G X)⁻¹ A + Q``
    with ``A = Fᵀ``, ``G = Hᵀ H``: ``A ← A W⁻¹ A``, ``G ← G + A W⁻¹ G Aᵀ``,
    ``X ← X + Aᵀ X W⁻¹ A``, ``W = I + G X``; ``X`` after k doublings is the Riccati
    iterate after 2^k steps, the error falls like ``ρ(L)^{2^{k+1}}``.
    """
    count, n = process.shape[0], transition.shape[0]
    a = np.broadcast_to(transition.T, (count, n, n)).copy()
    g = np.broadcast_to(observation.T @ observation, (count, n, n)).copy()
    x = _sym(process.copy())
    eye = np.eye(n)
    for _ in range(64):
        z = np.linalg.solve(eye + g @ x, np.concatenate([a, g], axis=2))
        wa, wg = z[..., :n], z[..., n:]
        x = _sym(x + _swap(a) @ x @ wa)
        g = _sym(g + a @ wg @ _swap(a))
        a = a @ wa
        if not np.all(np.isfinite(x)):
            break
        if np.max(np.abs(a)) <= 1e-9:
            return x
    raise ArithmeticError("no stationary covariance: the model is not detectable")


# --------------------------------------------------------------------------------------
# the two-car model
# --------------------------------------------------------------------------------------


def _matrix(name: str, value: ArrayLike, shape: tuple[int, int]) -> FloatArray:
    a = np.atleast_2d(np.asarray(value, dtype=float))
    if a.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains non-finite values")
    return a


@dataclass(frozen=True, eq=False)
class CarDynamics:
    """One car: ``M q̈ + C q̇ + K q = B L``, ``L = b P``, accelerometers ``a = O q̈``.

    ``mass`` M (n × n, symmetric positive definite), ``damping`` C and ``stiffness`` K
    (n × n, symmetric; K positive semi-definite, its null space the rigid-body motion,
    which C must not damp), ``load_map`` B (n × J: generalised force of each end load),
    ``sensor_map`` O (S × n), ``coupler_load`` b (J: end loads per unit compression-positive
    coupler force ``P``; a rod's rear car ``(0, −1)``, front car ``(−1, 0)``). In use: the
    rigid mode and the first elastic free-free modes of a car, mass-normalised
    (``M = I``, ``K = diag(ω²)``), but any M, C, K will do.
    """

    mass: FloatArray
    damping: FloatArray
    stiffness: FloatArray
    load_map: FloatArray
    sensor_map: FloatArray
    coupler_load: FloatArray

    def __post_init__(self) -> None:
        m = np.atleast_2d(np.asarray(self.mass, dtype=float))
        n = m.shape[0]
        bmap = np.asarray(self.load_map, dtype=float)
        bmap = bmap.reshape(n, -1) if bmap.ndim <= 1 else bmap
        omap = np.atleast_2d(np.asarray(self.sensor_map, dtype=float))
        b = np.asarray(self.coupler_load, dtype=float).reshape(-1)
        object.__setattr__(self, "mass", _matrix("mass", m, (n, n)))
        object.__setattr__(self, "damping", _matrix("damping", self.damping, (n, n)))
        object.__setattr__(self, "stiffness", _matrix("stiffness", self.stiffness, (n, n)))
        object.__setattr__(self, "load_map", _matrix("load_map", bmap, (n, bmap.shape[-1])))
        object.__setattr__(self, "sensor_map", _matrix("sensor_map", omap, (omap.shape[0], n)))
        if b.shape != (self.load_map.shape[1],) or not np.all(np.isfinite(b)):
            raise ValueError(f"coupler_load must be a finite vector of {self.load_map.shape[1]} end loads, got shape {b.shape}")
        object.__setattr__(self, "coupler_load", b)
        for name in ("mass", "damping", "stiffness"):
            a = getattr(self, name)
            if not np.allclose(a, a.T, rtol=1e-10, atol=1e-12 * np.max(np.abs(a), initial=0.0)):
                raise ValueError(f"{name} must be symmetric")

    @property
    def channels(self) -> int:
        """Number of accelerometer channels S."""
        return int(self.sensor_map.shape[0])


@dataclass(frozen=True)
class SensorFilter:
    """The analogue anti-alias low-pass every channel passes before it is sampled: a Butterworth of
    ``order`` at ``corner`` Hz, ``|H(iω)|² = 1/(1 + (ω/ω_c)^{2N})``, ``ω_c = 2π corner``.

    As states (unit DC gain): for ``k = 1 … ⌊N/2⌋`` a second-order section with damping ratio
    ``ζ_k = sin((2k − 1)π/(2N))`` and states ``(x, v = ẋ/ω_c)``::

        ẋ = ω_c v,   v̇ = ω_c (u − x − 2 ζ_k v)

    and, for odd ``N``, a first-order section ``ẋ = ω_c (u − x)``; the sections in cascade, the
    channel's model acceleration ``u`` into the first, the last section's ``x`` sampled. The poles
    are ``ω_c e^{iπ(2k+N−1)/(2N)}``, the analogue Butterworth's.
    """

    corner: float
    order: int = 4

    def __post_init__(self) -> None:
        _checks.positive("corner", self.corner)
        if not isinstance(self.order, int) or isinstance(self.order, bool) or not 1 <= self.order <= 8:
            raise ValueError(f"order must be an integer in 1 … 8, got {self.order!r}")

    def state_space(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(A_f, b_f, c_f)`` of one channel: ``ẇ = A_f w + b_f u``, sampled output ``c_f w``."""
        n, omega = self.order, 2.0 * math.pi * self.corner
        a, b = np.zeros((n, n)), np.zeros(n)
        previous = None  # state index of the previous section's output x
        row = 0
        for k in range(1, n // 2 + 1):
            zeta = math.sin((2 * k - 1) * math.pi / (2 * n))
            a[row, row + 1] = omega
            a[row + 1, row], a[row + 1, row + 1] = -omega, -2.0 * zeta * omega
            if previous is None:
                b[row + 1] = omega
            else:
                a[row + 1, previous] = omega
            previous, row = row, row + 2
        if n % 2:
            a[row, row] = -omega
            if previous is None:
                b[row] = omega
            else:
                a[row, previous] = omega
            previous = row
        out = np.zeros(n)
        out[previous] = 1.0
        return a, b, out


@dataclass(frozen=True, eq=False)
class CoupledCars:
    """The rear (hammer) and front (anvil) car joined by the coupler force ``P``.

    Accelerometer channels are ordered rear first, then front: a record is
    ``N × (S_rear + S_front)``. ``sensor_filter``: the recorders' anti-alias low-pass, one for
    every channel or one per channel (None: sampled unfiltered).
    """

    rear: CarDynamics
    front: CarDynamics
    sensor_filter: SensorFilter | tuple[SensorFilter | None, ...] | None = None

    def __post_init__(self) -> None:
        if isinstance(self.sensor_filter, tuple) and len(self.sensor_filter) != self.channels:
            raise ValueError(f"sensor_filter: one per channel ({self.channels}), got {len(self.sensor_filter)}")

    @property
    def channel_filters(self) -> tuple[SensorFilter | None, ...]:
        """Each channel's anti-alias filter (None: unfiltered)."""
        if isinstance(self.sensor_filter, tuple):
            return self.sensor_filter
        return (self.sensor_filter,) * self.channels

    @property
    def channels(self) -> int:
        """Total number of accelerometer channels."""
        return self.rear.channels + self.front.channels


@dataclass(frozen=True, eq=False)
class _ElasticBlock:
    """A car without its rigid motion: ``ẋ = A x + u P``, ``a = H x + d P``, ``x = (e, ė)``."""

    system: FloatArray  # (2k, 2k)
    input: FloatArray  # (2k,)
    output: FloatArray  # (S, 2k)
    feedthrough: FloatArray  # (S,)
    frequencies: FloatArray  # ω_j (k,)
    modal_force: FloatArray  # Φ_eᵀ B b (k,)


def _elastic_block(car: CarDynamics, name: str) -> _ElasticBlock:
    """Remove the rigid-body motion exactly (module docstring)."""
    try:
        lam, phi = eigh(car.stiffness, car.mass)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name} car: mass must be positive definite") from None
    top = float(np.max(np.abs(lam), initial=0.0))
    rigid = lam <= RIGID_TOLERANCE * top if top > 0.0 else np.ones(lam.size, dtype=bool)
    if np.any(lam[~rigid] < 0.0):
        raise ValueError(f"{name} car: stiffness must be positive semi-definite (eigenvalue {lam.min():.3g})")
    c_modal = phi.T @ car.damping @ phi
    scale = float(np.max(np.abs(c_modal), initial=0.0))
    if np.any(rigid) and scale > 0.0 and np.max(np.abs(c_modal[rigid])) > 1e-8 * scale:
        raise ValueError(f"{name} car: damping acts on the rigid-body motion (C Φ_r ≠ 0); internal damping must not")
    elastic = ~rigid
    k = int(np.sum(elastic))
    lam_e, phi_e, c_e = lam[elastic], phi[:, elastic], c_modal[np.ix_(elastic, elastic)]
    force = car.load_map @ car.coupler_load
    modal_force = phi_e.T @ force
    system = np.zeros((2 * k, 2 * k))
    system[:k, k:] = np.eye(k)
    system[k:, :k] = -np.diag(lam_e)
    system[k:, k:] = -c_e
    seen = car.sensor_map @ phi_e
    return _ElasticBlock(
        system=system,
        input=np.concatenate([np.zeros(k), modal_force]),
        output=np.hstack([-seen * lam_e, -seen @ c_e]),
        feedthrough=car.sensor_map @ np.linalg.solve(car.mass, force),
        frequencies=np.sqrt(lam_e),
        modal_force=modal_force,
    )


@dataclass(frozen=True, eq=False)
class AugmentedModel:
    """The augmented model ``z = [e_rear, ė_rear, e_front, ė_front, P]`` in scaled states.

    Physical states are ``z = D z̃`` with ``D = diag(state_unit)`` (modal coordinates of the
    mass-normalised elastic modes, their rates, and N); every matrix here acts on ``z̃``.
    ``system_matrix`` Ã and ``noise_input`` G̃ (continuous: ``ż̃ = Ã z̃ + G̃ w``),
    ``transition`` F̃ and ``unit_process_covariance`` Q̃₁ (``q_P = 1``) at ``step``;
    ``observation`` ``H D`` maps ``z̃`` to the accelerations (m/s²); ``noise_std`` σ per
    channel; ``quasi_static_direction`` ``u`` (scaled) the state of a unit coupler force in
    quasi-static equilibrium; ``undetectable`` the marginal eigenvalues failing the PBH test
    (empty for a sound model).
    """

    system_matrix: FloatArray
    noise_input: FloatArray
    transition: FloatArray
    unit_process_covariance: FloatArray
    observation: FloatArray
    noise_std: FloatArray
    state_unit: FloatArray
    quasi_static_direction: FloatArray
    step: float
    undetectable: tuple[complex, ...]

    @property
    def force_index(self) -> int:
        """Index of ``P`` in the state."""
        return int(self.transition.shape[0] - 1)

    @property
    def whitened_observation(self) -> FloatArray:
        """``R^{-1/2} H D``: the observation in units of each channel's noise std."""
        return self.observation / self.noise_std[:, None]

    def process_covariance(self, force_rate: float) -> FloatArray:
        """``Q̃ = q_P Q̃₁``."""
        return _checks.positive("force_rate", force_rate) * self.unit_process_covariance

    def stationary_covariance(self, force_rate: float) -> FloatArray:
        """``P̃∞``: the stationary predicted covariance (ArithmeticError if not detectable)."""
        q = self.process_covariance(force_rate)
        return _stationary_covariance(self.transition, q[None], self.whitened_observation)[0]

    def prior_covariance(self, force_rate: float, initial_force_std: float) -> FloatArray:
        """``P̃∞ + σ_0² u uᵀ``, the estimator's prior (module docstring; ``u`` is per newton)."""
        d = _checks.positive("initial_force_std", initial_force_std) ** 2
        u = self.quasi_static_direction
        return self.stationary_covariance(force_rate) + d * np.outer(u, u)


def augmented_model(model: CoupledCars, step: float, noise_std: float | ArrayLike) -> AugmentedModel:
    """The two cars without their rigid motion, plus the random-walk force, sampled at ``step`` (s)."""
    h = _checks.sample_step("step", step)
    sigma = _noise(noise_std, model.channels)
    blocks = [_elastic_block(model.rear, "rear"), _elastic_block(model.front, "front")]
    sizes = [b.system.shape[0] for b in blocks]
    n = sum(sizes) + 1
    a = np.zeros((n, n))
    hm = np.zeros((model.channels, n))
    u = np.zeros(n)
    u[-1] = 1.0
    row, col = 0, 0
    for b, size in zip(blocks, sizes):
        s, k = b.output.shape[0], size // 2
        a[col : col + size, col : col + size] = b.system
        a[col : col + size, -1] = b.input
        hm[row : row + s, col : col + size] = b.output
        hm[row : row + s, -1] = b.feedthrough
        u[col : col + k] = b.modal_force / b.frequencies**2
        row, col = row + s, col + size
    # state units: one unit of each state ≈ one noise std on the sensors
    norms = np.linalg.norm(hm / sigma[:, None], axis=0)
    unit = np.ones(n)
    unit[-1] = 1.0 / norms[-1] if norms[-1] > 0.0 else 1.0
    col = 0
    for b, size in zip(blocks, sizes):
        k = size // 2
        for j, w in enumerate(b.frequencies):
            seen = norms[col + j] / w**2  # ‖O φ_j / σ‖
            if seen > 0.0:
                unit[col + j] = 1.0 / (w**2 * seen)
            elif b.modal_force[j] != 0.0:
                unit[col + j] = abs(b.modal_force[j]) * unit[-1] / w**2
            unit[col + k + j] = unit[col + j] * w
        col += size
    if any(f is not None for f in model.channel_filters):
        a, hm, u, unit = _with_sensor_filters(model.channel_filters, a, hm, u, unit, sigma)
        n = a.shape[0]
    a_scaled = a * unit[None, :] / unit[:, None]
    g = np.zeros(n)
    g[-1] = 1.0 / unit[-1]
    transition, unit_process = van_loan_discretisation(a_scaled, g, 1.0, h)
    observation = hm * unit[None, :]
    return AugmentedModel(
        system_matrix=a_scaled,
        noise_input=g,
        transition=transition,
        unit_process_covariance=unit_process,
        observation=observation,
        noise_std=sigma,
        state_unit=unit,
        quasi_static_direction=u / unit,
        step=h,
        undetectable=_undetectable(a_scaled, observation / sigma[:, None]),
    )


def _with_sensor_filters(filters: tuple[SensorFilter | None, ...], a: FloatArray, hm: FloatArray, u: FloatArray, unit: FloatArray,
                         sigma: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The model with each channel's anti-alias filter (:class:`SensorFilter`) between its acceleration
    and its sample: ``z = [elastic states, filter states, P]``, a filter driven by its channel's ``hm z``
    and sampled as ``c_f w``; an unfiltered channel keeps its row of ``hm``. Filter states are in units
    of their channel's noise std; at a quasi-static force each holds its channel's DC value ``hm u``
    (the rigid acceleration) times ``−A_f⁻¹ b_f``."""
    n, channels = a.shape[0], hm.shape[0]
    spaces = [None if f is None else f.state_space() for f in filters]
    size = n + sum(0 if s is None else s[2].size for s in spaces)
    model = slice(0, n - 1)
    full = np.zeros((size, size))
    full[: n - 1, : n - 1] = a[model, model]
    full[: n - 1, -1] = a[model, -1]
    observation = np.zeros((channels, size))
    direction = np.zeros(size)
    direction[: n - 1], direction[-1] = u[model], u[-1]
    units = np.ones(size)
    units[: n - 1], units[-1] = unit[model], unit[-1]
    dc = hm @ u
    start = n - 1
    for c, space in enumerate(spaces):
        if space is None:
            observation[c, : n - 1], observation[c, -1] = hm[c, model], hm[c, -1]
            continue
        a_f, b_f, c_f = space
        block = slice(start, start + c_f.size)
        full[block, block] = a_f
        full[block, : n - 1] = np.outer(b_f, hm[c, model])
        full[block, -1] = b_f * hm[c, -1]
        observation[c, block] = c_f
        direction[block] = dc[c] * _dc_states(a_f, b_f)
        units[block] = sigma[c]
        start += c_f.size
    return full, observation, direction, units


def _dc_states(a_f: FloatArray, b_f: FloatArray) -> FloatArray:
    """The filter's states at a unit constant input: ``−A_f⁻¹ b_f``."""
    return -np.linalg.solve(a_f, b_f)


def forced_response(model: CoupledCars, time: ArrayLike, force: ArrayLike) -> FloatArray:
    """The model's samples ``y_k = H z_k`` (N × channels, m/s², no noise) under the prescribed coupler force
    ``P`` (N, on the uniform ``time``), from rest; exact for ``P`` linear between samples.

    With ``z = [x, P]`` (:func:`augmented_model`), ``ẋ = A_xx x + A_xP P``; over a step ``h`` with
    ``P = P_k + s τ``: ``x_{k+1} = Φ x_k + Γ₀ P_k + Γ₁ s``, ``[Φ Γ₀ Γ₁]`` the top rows of
    ``expm([[A_xx, A_xP, 0], [0, 0, 1], [0, 0, 0]] h)``.
    """
    t = _checks.time_grid("time", time, uniform=True, min_length=2)
    p = np.asarray(force, dtype=float)
    if p.shape != t.shape or not np.all(np.isfinite(p)):
        raise ValueError(f"force must be finite and of the time's shape {t.shape}")
    h = float(t[1] - t[0])
    aug = augmented_model(model, h, 1.0)
    n = aug.system_matrix.shape[0] - 1
    block = np.zeros((n + 2, n + 2))
    block[:n, : n + 1] = aug.system_matrix[:n, :]
    block[n, n + 1] = 1.0
    e = expm(block * h)
    phi, gamma0, gamma1 = e[:n, :n], e[:n, n], e[:n, n + 1]
    scaled = p / aug.state_unit[-1]
    slope = np.diff(scaled, append=scaled[-1]) / h
    states = np.empty((t.size, n))
    x = np.zeros(n)
    for k in range(t.size):
        states[k] = x
        x = phi @ x + gamma0 * scaled[k] + gamma1 * slope[k]
    return states @ aug.observation[:, :n].T + np.outer(scaled, aug.observation[:, n])


def _undetectable(system: FloatArray, observation: FloatArray) -> tuple[complex, ...]:
    """Marginal eigenvalues λ (Re λ ≥ −1e-9 ‖A‖) with ``rank [λI − A; H] < n`` (PBH)."""
    n = system.shape[0]
    size = max(float(np.linalg.norm(system, 2)), 1.0)
    hn = observation / max(float(np.linalg.norm(observation, 2)), 1e-300)
    bad: list[complex] = []
    for lam in np.linalg.eigvals(system):
        if lam.real < -1e-9 * size:
            continue
        pbh = np.vstack([(lam * np.eye(n) - system) / size, hn])
        if np.linalg.svd(pbh, compute_uv=False)[-1] < 1e-9:
            bad.append(complex(lam))
    return tuple(bad)


def _noise(noise_std: float | ArrayLike, channels: int) -> FloatArray:
    s = np.asarray(noise_std, dtype=float)
    s = np.full(channels, float(s)) if s.ndim == 0 else s
    if s.shape != (channels,) or not np.all(np.isfinite(s)) or np.any(s <= 0.0):
        raise ValueError(f"noise_std must be > 0, a scalar or one per channel ({channels}), got {noise_std!r}")
    return s


# --------------------------------------------------------------------------------------
# the O(dim²)-per-step estimator (stationary filter + initial-force regression)
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Steady:
    """Stationary filter quantities, batched over G force rates (scaled, whitened)."""

    covariance: FloatArray  # P∞ (G, n, n)
    innovation_inverse: FloatArray  # S∞⁻¹ (G, m, m)
    logdet: FloatArray  # log det S∞ (G,)
    drive: FloatArray  # F K∞ (G, n, m)
    closed_loop: FloatArray  # L = F (I − K∞ H) (G, n, n)


def _steady(aug: AugmentedModel, rates: FloatArray) -> _Steady:
    f, hw = aug.transition, aug.whitened_observation
    p = _stationary_covariance(f, rates[:, None, None] * aug.unit_process_covariance, hw)
    s = hw @ p @ hw.T + np.eye(hw.shape[0])
    s_inv = _sym(np.linalg.inv(s))
    gain = p @ hw.T @ s_inv
    return _Steady(p, s_inv, np.linalg.slogdet(s)[1], f @ gain, f - f @ gain @ hw)


def _steady_pass(steady: _Steady, hw: FloatArray, yw: FloatArray, u: FloatArray, extra: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """Predicted means of the stationary filter on the data (row 0) and ``L^k u`` (row 1), and
    ``L^k extra`` (row 2) if given: ``(rows (N, G, R, n), innovations ν∞ (N, G, m))``."""
    count, n = steady.covariance.shape[:2]
    steps = yw.shape[0]
    drive = np.einsum("gnm,km->kgn", steady.drive, yw)
    lt = np.ascontiguousarray(_swap(steady.closed_loop))
    rows = 2 if extra is None else 3
    state = np.zeros((count, rows, n))
    state[:, 1] = u
    if extra is not None:
        state[:, 2] = extra
    out = np.empty((steps, count, rows, n))
    if count == 1:
        s0, l0, d0 = state[0], lt[0], drive[:, 0]
        for k in range(steps):
            out[k, 0] = s0
            s0 = s0 @ l0
            s0[0] += d0[k]
    else:
        for k in range(steps):
            out[k] = state
            state = state @ lt
            state[:, 0] += drive[k]
    innovations = yw[:, None, :] - out[:, :, 0] @ hw.T
    return out, innovations


def _regression(steady: _Steady, hw: FloatArray, rows: FloatArray, innovations: FloatArray, prior: float) -> tuple[FloatArray, ...]:
    """``(ℓ_w, Σ ν S⁻¹ ν, E[α|y], Var[α|y])`` per G (whitened ℓ without constants)."""
    h = rows[:, :, 1] @ hw.T  # h_k = H L^k u (N, G, m)
    weighted = np.einsum("kgi,gij->kgj", innovations, steady.innovation_inverse)
    quad0 = np.einsum("kgj,kgj->g", weighted, innovations)
    s = np.einsum("kgj,kgj->g", weighted, h)
    o = np.einsum("kgi,gij,kgj->g", h, steady.innovation_inverse, h)
    info = 1.0 / prior + o
    quad = quad0 - s * s / info
    steps = innovations.shape[0]
    ell = -0.5 * (steps * steady.logdet + np.log1p(prior * o) + quad)
    return ell, quad, s / info, 1.0 / info


def _likelihoods(aug: AugmentedModel, yw: FloatArray, rates: FloatArray, prior: float) -> tuple[FloatArray, FloatArray]:
    """Whitened log-likelihoods (no constants) and ``Σ ν S⁻¹ ν`` for each force rate."""
    hw = aug.whitened_observation
    steady = _steady(aug, rates)
    rows, innovations = _steady_pass(steady, hw, yw, aug.quasi_static_direction)
    ell, quad, _, _ = _regression(steady, hw, rows, innovations, prior)
    return ell, quad


def _smoothed_force(aug: AugmentedModel, yw: FloatArray, rate: float, prior: float) -> tuple[FloatArray, FloatArray, float, float]:
    """Scaled smoothed force mean and variance, whitened ℓ and ``Σ ν S⁻¹ ν`` (module docstring)."""
    hw, i = aug.whitened_observation, aug.force_index
    steady = _steady(aug, np.array([rate]))
    p = steady.covariance[0]
    column = p[:, i]
    rows, innovations = _steady_pass(steady, hw, yw, aug.quasi_static_direction, extra=column)
    ell, quad, alpha, alpha_var = (float(v[0]) for v in _regression(steady, hw, rows, innovations, prior))
    rows, nu = rows[:, 0], innovations[:, 0]
    s_inv_h = steady.innovation_inverse[0] @ hw
    h = rows[:, 1] @ hw.T
    drive = np.stack([nu @ s_inv_h, -h @ s_inv_h], axis=1)  # Hᵀ S⁻¹ ν for the data and for ν = −h
    closed = steady.closed_loop[0]
    r = np.zeros((2, hw.shape[1]))
    adjoint = np.empty_like(drive)
    for k in range(yw.shape[0] - 1, -1, -1):
        r = drive[k] + r @ closed  # r_{k−1} = Hᵀ S⁻¹ ν_k + Lᵀ r_k
        adjoint[k] = r
    data_mean = rows[:, 0, i] + adjoint[:, 0] @ column
    response = rows[:, 1, i] + adjoint[:, 1] @ column  # ψ_k
    c = rows[:, 2] @ hw.T  # H L^j P∞ e_P
    terms = np.einsum("ki,ij,kj->k", c, steady.innovation_inverse[0], c)
    gathered = np.cumsum(terms)[::-1]  # Σ_{j < N−k}
    variance = np.maximum(p[i, i] - gathered, 0.0) + alpha_var * response**2
    return data_mean + alpha * response, variance, ell, quad


def _reference_force(aug: AugmentedModel, yw: FloatArray, rate: float, prior: float) -> tuple[FloatArray, FloatArray, float, float]:
    """The same outputs by the Joseph-form reference, prior ``N(0, prior u uᵀ)`` (undetectable models)."""
    u = aug.quasi_static_direction
    n = u.size
    out = _joseph_smoother(aug.transition, aug.process_covariance(rate), aug.whitened_observation, yw, np.zeros(n), prior * np.outer(u, u))
    i = aug.force_index
    _, _, _, _, xs, vs, _, _, logdet, quad = out
    return xs[:, i], vs[:, i, i], -0.5 * float(np.sum(logdet + quad)), float(np.sum(quad))


# --------------------------------------------------------------------------------------
# the public estimator
# --------------------------------------------------------------------------------------


NOISE_SCALES: tuple[str, ...] = ("declared", "estimated")


@dataclass(frozen=True, eq=False)
class ForceEstimate:
    """The smoothed coupler force (N, compression positive) and its diagnostics.

    ``force``/``force_std`` are the smoothed posterior mean and std at each sample,
    ``lower``/``upper`` the pointwise 95 % band ``force ∓ 1.96 force_std``. ``peak_force``
    is the maximum of ``force``, at ``peak_time``; ``peak_lower``/``peak_upper`` the band at
    that sample (module docstring). ``force_rate`` is the chosen ``q_P`` (N²/s),
    ``log_likelihood`` ``ℓ`` there (with its constants; concentrated over the noise scale
    if that was estimated), ``at_edge`` whether the likelihood optimum lies on the searched
    range's edge, ``nis`` the mean normalised innovation squared per channel of the filter
    used (≈ 1 if its noise is right; ≡ 1 when the noise scale is estimated),
    ``noise_scale`` the factor applied to the declared noise std (1 if declared,
    ``√λ̂`` if estimated), ``status`` "ok" or the reasons not to trust the estimate.
    ``force_rate_grid``/``log_likelihood_grid`` are all the force rates tried and their ℓ
    (empty if ``q_P`` was given).
    """

    time: FloatArray
    force: FloatArray
    force_std: FloatArray
    lower: FloatArray
    upper: FloatArray
    peak_force: float
    peak_time: float
    peak_lower: float
    peak_upper: float
    force_rate: float
    log_likelihood: float
    at_edge: bool
    nis: float
    noise_scale: float
    status: str
    force_rate_range: tuple[float, float]
    force_rate_grid: FloatArray = field(repr=False)
    log_likelihood_grid: FloatArray = field(repr=False)


def _search(
    evaluate: Callable[[FloatArray], FloatArray], low: float, high: float, points: int
) -> tuple[float, bool, FloatArray, FloatArray]:
    """Maximise ``evaluate(log10 q)`` (batched): coarse grid, two 3× finer rounds, a parabolic step.

    Returns ``(log10 q*, at_edge, all log10 q tried (sorted), their values)``.
    """
    logs = np.linspace(math.log10(low), math.log10(high), points)
    values = evaluate(logs)
    best = int(np.argmax(values))
    if best in (0, points - 1):
        return float(logs[best]), True, logs, values
    tried = dict(zip(logs.tolist(), values.tolist()))
    centre, spacing = float(logs[best]), float(logs[1] - logs[0])
    for _ in range(2):
        spacing /= 3.0
        new = centre + spacing * np.array([-2.0, -1.0, 1.0, 2.0])
        tried.update(zip(new.tolist(), evaluate(new).tolist()))
        centre = max(tried, key=tried.__getitem__)
    keys = sorted(tried)
    at = keys.index(centre)
    if 0 < at < len(keys) - 1:  # parabola through the best point and its neighbours
        (a, fa), (b, fb), (c, fc) = ((x, tried[x]) for x in keys[at - 1 : at + 2])
        num = (b - a) ** 2 * (fb - fc) - (b - c) ** 2 * (fb - fa)
        den = (b - a) * (fb - fc) - (b - c) * (fb - fa)
        if den != 0.0:
            vertex = b - 0.5 * num / den
            if a < vertex < c and vertex not in tried:
                tried[vertex] = float(evaluate(np.array([vertex]))[0])
    keys = sorted(tried)
    vals = np.array([tried[k] for k in keys])
    return float(keys[int(np.argmax(vals))]), False, np.array(keys), vals


def _status(
    at_edge: bool, variance_ratio: float, estimated: bool, nis_range: tuple[float, float], aug: AugmentedModel, rates: tuple[float, float], q: float
) -> str:
    reasons = []
    if aug.undetectable:
        reasons.append(
            "force not detectable from these accelerations (PBH fails at λ = "
            + ", ".join(f"{lam:.3g}" for lam in aug.undetectable)
            + "): its variance grows without bound; a grounded model needs dummy displacement measurements"
        )
    if at_edge:
        name = "q_P/λ̂" if estimated else "q_P"
        reasons.append(f"likelihood optimum at the edge of the force-rate range [{rates[0]:.3g}, {rates[1]:.3g}] N²/s ({name} = {q:.3g})")
    if not nis_range[0] <= variance_ratio <= nis_range[1]:
        expected = f"expected in [{nis_range[0]:.3g}, {nis_range[1]:.3g}]"
        if estimated:
            reasons.append(
                f"innovations inconsistent with the declared noise: they need its variance ×{variance_ratio:.3g} ({expected}); "
                "model error or a wrong noise level"
            )
        else:
            reasons.append(
                f"innovations inconsistent with the declared noise (NIS = {variance_ratio:.3g}, {expected}); "
                "model error or a wrong noise level (see noise_scale='estimated' and model variants)"
            )
    return "; ".join(reasons) if reasons else "ok"


def estimate_force(
    model: CoupledCars,
    time: ArrayLike,
    accelerations: ArrayLike,
    noise_std: float | ArrayLike,
    *,
    force_rate: float | None = None,
    force_rate_range: tuple[float, float] = DEFAULT_FORCE_RATE_RANGE,
    grid_points: int = 15,
    initial_force_std: float = 1.0e5,
    noise_scale: str = "declared",
    nis_range: tuple[float, float] = (0.5, 2.0),
) -> ForceEstimate:
    """Smoothed coupler force ``P(t)`` from the cars' accelerations (equations in the module docstring).

    ``time`` (s, uniform, N samples), ``accelerations`` (m/s², N × channels, rear car's
    channels first), ``noise_std`` (m/s², scalar or per channel). ``force_rate`` fixes
    ``q_P`` (N²/s); otherwise the innovation likelihood is maximised over ``grid_points``
    log-spaced values in ``force_rate_range`` and refined. Prior: cars undeformed up to the
    stationary filter uncertainty, and an initial force ``~ N(0, initial_force_std²)`` (N) in
    quasi-static equilibrium. ``noise_scale``: ``"declared"`` trusts ``noise_std``;
    ``"estimated"`` multiplies all covariances by the ML scale ``λ̂`` (the likelihood
    concentrated over it, module docstring) so that model error shows as noise instead
    of driving ``q_P``; ``force_rate``, ``force_rate_range`` and the grid then refer to
    ``q_P/λ̂`` (the rate per unit of the declared noise variance), the reported
    ``force_rate`` is ``q_P``. ``nis_range``: the NIS (or ``λ̂``) accepted as consistent.
    """
    t = _checks.time_grid("time", time, uniform=True)
    y = np.asarray(accelerations, dtype=float)
    y = y.reshape(-1, 1) if y.ndim == 1 else y
    if y.ndim != 2 or y.shape != (t.size, model.channels) or not np.all(np.isfinite(y)):
        raise ValueError(f"accelerations must be finite, N × channels = {(t.size, model.channels)}, got shape {y.shape}")
    lo = _checks.positive("force_rate_range[0]", force_rate_range[0])
    hi = _checks.positive("force_rate_range[1]", force_rate_range[1])
    if not lo < hi:
        raise ValueError(f"force_rate_range must be increasing, got {force_rate_range!r}")
    if int(grid_points) != grid_points or grid_points < 3:
        raise ValueError(f"grid_points must be an integer >= 3, got {grid_points!r}")
    force_std0 = _checks.positive("initial_force_std", initial_force_std)
    estimated = _checks.choice("noise_scale", noise_scale, NOISE_SCALES) == "estimated"
    if not 0.0 < nis_range[0] < nis_range[1]:
        raise ValueError(f"nis_range must satisfy 0 < low < high, got {nis_range!r}")

    aug = augmented_model(model, float(t[1] - t[0]), noise_std)
    yw = y / aug.noise_std[None, :]
    prior = force_std0**2  # N²: u is the scaled state of one newton
    steps, m = y.shape
    count = steps * m
    constant = -0.5 * (count * math.log(2.0 * math.pi) + 2.0 * steps * float(np.sum(np.log(aug.noise_std))))
    detectable = not aug.undetectable

    def objective(ell_w: FloatArray, quad: FloatArray) -> FloatArray:
        """ℓ with constants; concentrated: ``λ̂ = Σ ν S̃⁻¹ ν/(N m)``, ``ℓ = −½ (N m log λ̂ + Σ log det S̃ + N m)``."""
        if not estimated:
            return ell_w + constant
        logdets = -2.0 * ell_w - quad
        return -0.5 * (count * np.log(quad / count) + logdets + count) + constant

    def evaluate(logs: FloatArray) -> FloatArray:
        rates = 10.0**logs
        if detectable:
            return objective(*_likelihoods(aug, yw, rates, prior))
        pairs = np.array([_reference_force(aug, yw, float(q), prior)[2:] for q in rates])
        return objective(pairs[:, 0], pairs[:, 1])

    grid, grid_ell, at_edge = np.empty(0), np.empty(0), False
    if force_rate is not None:
        q = _checks.positive("force_rate", force_rate)
    else:
        s_best, at_edge, grid_logs, grid_ell = _search(evaluate, lo, hi, int(grid_points))
        q, grid = 10.0**s_best, 10.0**grid_logs
    smoother = _smoothed_force if detectable else _reference_force
    mean, var, ell_w, quad = smoother(aug, yw, q, prior)
    ratio = quad / count  # NIS against the declared noise, = λ̂ when it is estimated
    scale = ratio if estimated else 1.0
    unit = aug.state_unit[-1]
    force, std = mean * unit, np.sqrt(var * scale) * unit
    k = int(np.argmax(force))
    return ForceEstimate(
        time=t,
        force=force,
        force_std=std,
        lower=force - Z95 * std,
        upper=force + Z95 * std,
        peak_force=float(force[k]),
        peak_time=float(t[k]),
        peak_lower=float(force[k] - Z95 * std[k]),
        peak_upper=float(force[k] + Z95 * std[k]),
        force_rate=float(q * scale),
        log_likelihood=float(objective(np.array([ell_w]), np.array([quad]))[0]),
        at_edge=bool(at_edge),
        nis=float(ratio / scale),
        noise_scale=float(math.sqrt(scale)),
        status=_status(at_edge, ratio, estimated, nis_range, aug, (lo, hi), q),
        force_rate_range=(lo, hi),
        force_rate_grid=grid,
        log_likelihood_grid=grid_ell,
    )


@dataclass(frozen=True, eq=False)
class VariantForceEstimate:
    """The nominal estimate with its band widened to cover perturbed models (module docstring).

    ``estimates[0]`` is the nominal model's :class:`ForceEstimate`, the others the
    variants'. ``force`` and ``peak_force``/``peak_time`` are the nominal's; ``lower``/``upper``
    the envelope of all 95 % bands; ``peak_lower``/``peak_upper`` the envelope of all peak
    bands. ``status`` is the nominal's; ``variant_status`` every model's.
    """

    time: FloatArray
    force: FloatArray
    lower: FloatArray
    upper: FloatArray
    peak_force: float
    peak_time: float
    peak_lower: float
    peak_upper: float
    status: str
    variant_status: tuple[str, ...]
    estimates: tuple[ForceEstimate, ...] = field(repr=False)

    @property
    def nominal(self) -> ForceEstimate:
        return self.estimates[0]


def estimate_force_with_variants(
    models: Sequence[CoupledCars],
    time: ArrayLike,
    accelerations: ArrayLike,
    noise_std: float | ArrayLike,
    **options: object,
) -> VariantForceEstimate:
    """:func:`estimate_force` on each model (``models[0]`` nominal); band = envelope of the bands.

    ``options`` are passed to :func:`estimate_force`; each model gets its own ``q_P`` and,
    unless ``noise_scale`` is given, its own noise scale (``noise_scale="estimated"``:
    a variant is by construction not the true model, and its misfit must show as noise,
    not as force — module docstring).
    """
    if len(models) < 1:
        raise ValueError("models must hold at least the nominal model")
    options = {"noise_scale": "estimated", **options}
    estimates = tuple(estimate_force(mdl, time, accelerations, noise_std, **options) for mdl in models)  # type: ignore[arg-type]
    nominal = estimates[0]
    return VariantForceEstimate(
        time=nominal.time,
        force=nominal.force,
        lower=np.min([e.lower for e in estimates], axis=0),
        upper=np.max([e.upper for e in estimates], axis=0),
        peak_force=nominal.peak_force,
        peak_time=nominal.peak_time,
        peak_lower=min(e.peak_lower for e in estimates),
        peak_upper=max(e.peak_upper for e in estimates),
        status=nominal.status,
        variant_status=tuple(e.status for e in estimates),
        estimates=estimates,
    )


__all__ = [
    "DEFAULT_FORCE_RATE_RANGE",
    "AugmentedModel",
    "CarDynamics",
    "CoupledCars",
    "ForceEstimate",
    "GaussianSmoothing",
    "NOISE_SCALES",
    "VariantForceEstimate",
    "SensorFilter",
    "augmented_model",
    "estimate_force",
    "estimate_force_with_variants",
    "forced_response",
    "kalman_smoother",
    "van_loan_discretisation",
]
