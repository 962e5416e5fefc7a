"""The filter's model of two coupled cars or a line of them (:func:`augmented_model`,
:class:`AugmentedModel`): the rigid-body motion removed exactly, the random-walk forces appended, the recorders' filter states
joined, sampled exactly, whitened and scaled, detectability checked; :func:`forced_response`, its
noise-free samples under prescribed forces;
:func:`undetectable_couplers`, the couplers no instrumented car feels.

Rigid-body motion and drift (Naets, Cuadrado & Desmet, MSSP 2015). Write ``q = Φ_r r + Φ_e e``
with the mass-normalised modes of ``(K, M)``: ``Φ_r`` spans the null space of ``K`` (rigid
motion), ``Λ_e = diag(ω_j²)``. Internal forces do no work on rigid motion, ``K Φ_r = 0`` and
``C Φ_r = 0`` (checked; a model that breaks it is refused), so::

    r̈ = Φ_rᵀ B B_c P,   ë + C_ee ė + Λ_e e = Φ_eᵀ B B_c P,   a = O M⁻¹ B B_c P − O Φ_e (Λ_e e + C_ee ė)

The rigid displacement ``r`` *and velocity* ``ṙ`` enter no output and no other state's
equation: unobservable and exactly disconnected, they are removed (exactly), and the car
speeds do not enter; the rigid acceleration of car ``i``, ``(P_{i−1} − P_i)/M_i`` in a line,
is carried by the feedthrough ``O M⁻¹ B B_c``. The filter state is::

    z = [e_1, ė_1, …, e_N, ė_N, P_1 … P_{n_c}]   (two cars: [e_rear, ė_rear, e_front, ė_front, P])

each ``P_c`` a random walk of the same intensity ``q_P``; a car without sensors keeps its
elastic states and gives no output row.

What remains is observable, so no dummy measurement is needed: the quasi-static part of
``P``, which an acceleration-only filter on a *grounded* structure cannot see, is seen here
as the rigid-body acceleration, ``M a_rigid = ±P``, of a free car (a dummy "elastic
displacement = 0" measurement would pull the force towards zero: the deformation responds
to ``P``). The premise is checked on every model by the PBH test on the marginal
eigenvalues, ``rank [λI − A; H] = dim z`` for ``Re λ ≥ 0``; a model that fails it (e.g.
grounded cars) gets the status "force not detectable ...". A force ``P_c`` is undetectable when
the null vector of ``[λI − A; H]`` at a failing ``λ`` has a ``P_c`` component
(:func:`undetectable_couplers`): in a line, when the cars on both sides of the coupler are
uninstrumented to the line's ends.

Discretisation at the record's step ``h``, exact for the random-walk state (a zero-order
hold on ``P`` is not: ``P`` varies inside the step). With ``ż = A z + G w``, ``G`` the last ``n_c``
columns of the identity
(Van Loan 1978)::

    expm([[−A, q_P G Gᵀ], [0, Aᵀ]] h) = [[·, E12], [0, E22]],
    F = E22ᵀ = e^{Ah},   Q = F E12 = ∫₀ʰ e^{Aτ} q_P G Gᵀ e^{Aᵀτ} dτ

``Q`` is linear in ``q_P``: computed once for ``q_P = 1`` and scaled. Samples:
``y_k = H z_k + v_k``, ``v_k ~ N(0, R)``, ``R = diag(σ_i²)``. Internally the outputs are
whitened (``R = I``) and the states scaled so that one unit of each is about one noise
std on the sensors (conditioning).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import eigh, expm

from reduced import _checks

from .cars import CarDynamics, ConsistCars, CoupledCars, SensorFilter
from .linear_gaussian import stationary_covariances, van_loan_discretisation

RIGID_TOLERANCE = 1e-9  # ω² ≤ this × max ω² counts as a rigid-body mode

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class _ElasticBlock:
    """A car without its rigid motion: ``ẋ = A x + U P``, ``a = H x + D P``, ``x = (e, ė)``."""

    system: FloatArray  # (2k, 2k)
    input: FloatArray  # (2k, n_c)
    output: FloatArray  # (S, 2k)
    feedthrough: FloatArray  # (S, n_c)
    frequencies: FloatArray  # ω_j (k,)
    modal_force: FloatArray  # Φ_eᵀ B B_c (k, n_c)


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
    force = car.load_map @ car.coupler_map
    modal_force = phi_e.T @ force
    system = np.zeros((2 * k, 2 * k))
    system[:k, k:] = np.eye(k)
    system[k:, :k] = -np.diag(lam_e)
    system[k:, k:] = -c_e
    seen = car.sensor_map @ phi_e
    return _ElasticBlock(
        system=system,
        input=np.vstack([np.zeros((k, force.shape[1])), modal_force]),
        output=np.hstack([-seen * lam_e, -seen @ c_e]),
        feedthrough=car.sensor_map @ np.linalg.solve(car.mass, force),
        frequencies=np.sqrt(lam_e),
        modal_force=modal_force,
    )


@dataclass(frozen=True, eq=False)
class AugmentedModel:
    """The augmented model ``z = [elastic states, filter states, P_1 … P_{n_c}]`` in scaled states.

    Physical states are ``z = D z̃`` with ``D = diag(state_unit)`` (modal coordinates of the
    mass-normalised elastic modes, their rates, and N); every matrix here acts on ``z̃``.
    ``system_matrix`` Ã and ``noise_input`` G̃ (n × n_c; continuous: ``ż̃ = Ã z̃ + G̃ w``),
    ``transition`` F̃ and ``unit_process_covariance`` Q̃₁ (``q_P = 1``) at ``step``;
    ``observation`` ``H D`` maps ``z̃`` to the accelerations (m/s²); ``noise_std`` σ per
    channel; ``quasi_static_directions`` ``U`` (n × n_c, scaled): column ``c`` the state of a unit
    force ``P_c`` in quasi-static equilibrium; ``undetectable`` the marginal eigenvalues failing
    the PBH test (empty for a sound model).
    """

    system_matrix: FloatArray
    noise_input: FloatArray
    transition: FloatArray
    unit_process_covariance: FloatArray
    observation: FloatArray
    noise_std: FloatArray
    state_unit: FloatArray
    quasi_static_directions: FloatArray
    step: float
    undetectable: tuple[complex, ...]

    @property
    def couplers(self) -> int:
        """Number of coupler forces n_c."""
        return int(self.noise_input.shape[1])

    @property
    def force_slice(self) -> slice:
        """Where ``P_1 … P_{n_c}`` sit in the state (the last n_c entries)."""
        n = self.transition.shape[0]
        return slice(n - self.couplers, n)

    @property
    def force_index(self) -> int:
        """Index of ``P`` in the state of a one-coupler model."""
        if self.couplers != 1:
            raise ValueError(f"force_index: the model has {self.couplers} coupler forces (force_slice)")
        return int(self.transition.shape[0] - 1)

    @property
    def quasi_static_direction(self) -> FloatArray:
        """``u``: the one coupler's column of ``quasi_static_directions``."""
        if self.couplers != 1:
            raise ValueError(f"quasi_static_direction: the model has {self.couplers} coupler forces (quasi_static_directions)")
        return self.quasi_static_directions[:, 0]

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
        return stationary_covariances(self.transition, q[None], self.whitened_observation)[0]

    def prior_covariance(self, force_rate: float, initial_force_std: float) -> FloatArray:
        """``P̃∞ + σ_0² U Uᵀ``, the estimator's prior (:mod:`.steady`; ``U`` is per newton, the
        couplers' initial forces independent)."""
        d = _checks.positive("initial_force_std", initial_force_std) ** 2
        u = self.quasi_static_directions
        return self.stationary_covariance(force_rate) + d * (u @ u.T)


def augmented_model(model: CoupledCars | ConsistCars, step: float, noise_std: float | ArrayLike) -> AugmentedModel:
    """The cars without their rigid motion, plus the random-walk coupler forces, sampled at ``step`` (s)."""
    h = _checks.sample_step("step", step)
    sigma = _noise(noise_std, model.channels)
    names = ("rear", "front") if isinstance(model, CoupledCars) else tuple(f"cars[{i}]" for i in range(len(model.cars)))
    blocks = [_elastic_block(car, name) for car, name in zip(model.cars, names)]
    sizes = [b.system.shape[0] for b in blocks]
    nc = model.couplers
    forces = slice(sum(sizes), sum(sizes) + nc)
    n = sum(sizes) + nc
    a = np.zeros((n, n))
    hm = np.zeros((model.channels, n))
    u = np.zeros((n, nc))
    u[forces] = np.eye(nc)
    row, col = 0, 0
    for b, size in zip(blocks, sizes):
        s, k = b.output.shape[0], size // 2
        a[col : col + size, col : col + size] = b.system
        a[col : col + size, forces] = b.input
        hm[row : row + s, col : col + size] = b.output
        hm[row : row + s, forces] = b.feedthrough
        u[col : col + k] = b.modal_force / b.frequencies[:, None] ** 2
        row, col = row + s, col + size
    # state units: one unit of each state ≈ one noise std on the sensors
    norms = np.linalg.norm(hm / sigma[:, None], axis=0)
    unit = np.ones(n)
    unit[forces] = [1.0 / v if v > 0.0 else 1.0 for v in norms[forces]]
    col = 0
    for b, size in zip(blocks, sizes):
        k = size // 2
        for j, w in enumerate(b.frequencies):
            seen = norms[col + j] / w**2  # ‖O φ_j / σ‖
            if seen > 0.0:
                unit[col + j] = 1.0 / (w**2 * seen)
            elif np.any(b.modal_force[j] != 0.0):
                unit[col + j] = float(np.max(np.abs(b.modal_force[j]) * unit[forces])) / w**2
            unit[col + k + j] = unit[col + j] * w
        col += size
    if any(f is not None for f in model.channel_filters):
        a, hm, u, unit = _with_sensor_filters(model.channel_filters, a, hm, u, unit, sigma)
        n = a.shape[0]
    a_scaled = a * unit[None, :] / unit[:, None]
    g = np.zeros((n, nc))
    g[n - nc :] = np.diag(1.0 / unit[n - nc :])
    transition, unit_process = van_loan_discretisation(a_scaled, g, np.eye(nc), h)
    observation = hm * unit[None, :]
    return AugmentedModel(
        system_matrix=a_scaled,
        noise_input=g,
        transition=transition,
        unit_process_covariance=unit_process,
        observation=observation,
        noise_std=sigma,
        state_unit=unit,
        quasi_static_directions=u / unit[:, None],
        step=h,
        undetectable=_undetectable(a_scaled, observation / sigma[:, None]),
    )


def _with_sensor_filters(filters: tuple[SensorFilter | None, ...], a: FloatArray, hm: FloatArray, u: FloatArray, unit: FloatArray,
                         sigma: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The model with each channel's anti-alias filter (:class:`SensorFilter`) between its acceleration
    and its sample: ``z = [elastic states, filter states, P_1 … P_{n_c}]``, a filter driven by its channel's
    ``hm z`` and sampled as ``c_f w``; an unfiltered channel keeps its row of ``hm``. Filter states are in
    units of their channel's noise std; at quasi-static forces each holds its channel's DC value ``hm U``
    (the rigid acceleration) times ``−A_f⁻¹ b_f``."""
    n, channels, nc = a.shape[0], hm.shape[0], u.shape[1]
    m = n - nc
    spaces = [None if f is None else f.state_space() for f in filters]
    size = n + sum(0 if s is None else s[2].size for s in spaces)
    model, forces, moved = slice(0, m), slice(m, n), slice(size - nc, size)
    full = np.zeros((size, size))
    full[:m, :m] = a[model, model]
    full[:m, moved] = a[model, forces]
    observation = np.zeros((channels, size))
    direction = np.zeros((size, nc))
    direction[:m], direction[moved] = u[model], u[forces]
    units = np.ones(size)
    units[:m], units[moved] = unit[model], unit[forces]
    dc = hm @ u
    start = m
    for c, space in enumerate(spaces):
        if space is None:
            observation[c, :m], observation[c, moved] = hm[c, model], hm[c, forces]
            continue
        a_f, b_f, c_f = space
        block = slice(start, start + c_f.size)
        full[block, block] = a_f
        full[block, :m] = np.outer(b_f, hm[c, model])
        full[block, moved] = np.outer(b_f, hm[c, forces])
        observation[c, block] = c_f
        direction[block] = np.outer(_dc_states(a_f, b_f), dc[c])
        units[block] = sigma[c]
        start += c_f.size
    return full, observation, direction, units


def _dc_states(a_f: FloatArray, b_f: FloatArray) -> FloatArray:
    """The filter's states at a unit constant input: ``−A_f⁻¹ b_f``."""
    return -np.linalg.solve(a_f, b_f)


def forced_response(model: CoupledCars | ConsistCars, time: ArrayLike, force: ArrayLike) -> FloatArray:
    """The model's samples ``y_k = H z_k`` (N × channels, m/s², no noise) under the prescribed coupler forces
    (N; on the uniform ``time``, N × n_c or a vector for one coupler), from rest; exact for forces linear
    between samples.

    With ``z = [x, P]`` (:func:`augmented_model`), ``ẋ = A_xx x + A_xP P``; over a step ``h`` with
    ``P = P_k + s τ``: ``x_{k+1} = Φ x_k + Γ₀ P_k + Γ₁ s``, ``[Φ Γ₀ Γ₁]`` the top rows of
    ``expm([[A_xx, A_xP, 0], [0, 0, I], [0, 0, 0]] h)``.
    """
    t = _checks.time_grid("time", time, uniform=True, min_length=2)
    return forced_samples(augmented_model(model, float(t[1] - t[0]), 1.0), t, force)


def forced_samples(aug: AugmentedModel, time: FloatArray, force: ArrayLike) -> FloatArray:
    """:func:`forced_response` of the model ``aug`` was built from, on its step (any noise: the samples are in m/s²)."""
    t = np.asarray(time, dtype=float)
    p = np.asarray(force, dtype=float)
    nc = aug.couplers
    p = p.reshape(-1, 1) if p.ndim == 1 and nc == 1 else p
    if p.shape != (t.size, nc) or not np.all(np.isfinite(p)):
        raise ValueError(f"force must be finite, {t.size} samples × {nc} couplers, got shape {np.shape(force)}")
    h = aug.step
    n = aug.system_matrix.shape[0] - nc
    block = np.zeros((n + 2 * nc, n + 2 * nc))
    block[:n, : n + nc] = aug.system_matrix[:n, :]
    block[n : n + nc, n + nc :] = np.eye(nc)
    e = expm(block * h)
    phi, gamma0, gamma1 = e[:n, :n], e[:n, n : n + nc], e[:n, n + nc :]
    scaled = p / aug.state_unit[n:]
    slope = np.diff(scaled, axis=0, append=scaled[-1:]) / h
    states = np.empty((t.size, n))
    x = np.zeros(n)
    for k in range(t.size):
        states[k] = x
        x = phi @ x + gamma0 @ scaled[k] + gamma1 @ slope[k]
    return states @ aug.observation[:, :n].T + scaled @ aug.observation[:, n:].T


def undetectable_couplers(aug: AugmentedModel, threshold: float = 1e-6) -> tuple[tuple[complex, tuple[int, ...]], ...]:
    """For each undetectable ``λ`` of ``aug`` (PBH, :func:`augmented_model`), the couplers (0-based) whose
    force component in the null space of ``[λI − A; H]`` is nonzero: ``|v_{P_c}| > threshold ‖v‖`` for a
    null vector ``v`` (scaled states), each distinct λ once; a λ of the elastic states alone names none."""
    a, hw = aug.system_matrix, aug.whitened_observation
    n, forces = a.shape[0], aug.force_slice
    size = max(float(np.linalg.norm(a, 2)), 1.0)
    hn = hw / max(float(np.linalg.norm(hw, 2)), 1e-300)
    named: list[tuple[complex, tuple[int, ...]]] = []
    for lam in aug.undetectable:
        if any(abs(lam - seen) <= 1e-9 * size for seen, _ in named):
            continue  # a repeated eigenvalue: its null space is taken whole below
        _, singular, vh = np.linalg.svd(np.vstack([(lam * np.eye(n) - a) / size, hn]))
        null = vh[singular < 1e-9].conj().T if np.any(singular < 1e-9) else vh[-1:].conj().T
        part = np.abs(null[forces]) > threshold * np.linalg.norm(null, axis=0)
        named.append((lam, tuple(int(c) for c in np.flatnonzero(np.any(part, axis=1)))))
    return tuple(named)


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


__all__ = [
    "AugmentedModel",
    "augmented_model",
    "forced_response",
    "undetectable_couplers",
]
