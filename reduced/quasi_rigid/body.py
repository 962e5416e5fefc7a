"""What the quasi-rigid rod and beam share: loads, results, frequency and time responses.

Every quasi-rigid model is linear in its end loads ``L_j`` and has the two-term form

    a(x, t) = Σ_j R_j(x) L_j(t) + Σ_j Σ_g C[x, j, g] · L_{τ_g}[L̈_j](t),

rigid-body acceleration plus the second time derivative of the creep correction
(:mod:`.correction`). In the frequency domain (``e^{−iωt}``) the same reads

    a(x, ω) = Σ_j [R_j(x) − ω² Σ_g C[x, j, g] / (1 − iωτ_g)] L_j,

the two-term generalisation of ``a* = 1 + q²/6`` (a complex, frequency-dependent mass).

**Second derivatives of the load.** Sampled loads are taken as piecewise linear, and the
acceleration at ``t_n`` is the filter applied to the central second differences
``(L_{n+1} − 2L_n + L_{n−1})/dt²``: by linearity and shift invariance of the filter this is
the exact quasi-rigid acceleration of the piecewise-linear load averaged with the hat weight
over ``[t_{n−1}, t_{n+1}]`` (error ``(dt²/12) ∂⁴y/∂t⁴`` for a smooth load, relative to the O(ε)
correction only). Velocities likewise use central first differences. A :class:`LoadHistory`
with analytic derivatives uses the samples of ``L̇`` and ``L̈`` instead (kinks then ignored).

Before ``t₀`` the load is held at ``L(t₀)`` with the body in quasi-static equilibrium;
displacements count from that initial position and shape. The last sample's differences
use a quadratic extrapolation of the load.

Verified: tests/reduced/quasi_rigid/test_frequency.py, tests/reduced/quasi_rigid/test_time.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .correction import CreepCorrection
from .creep import CreepKernel, harmonic_factor, harmonic_factor_at, update_coefficients
from .profiles import BodyQuadrature


@dataclass(frozen=True)
class LoadHistory:
    """An end-load history with optional analytic derivatives (N or N·m; per s, per s²)."""

    value: Callable[[NDArray[np.float64]], ArrayLike]
    first_derivative: Callable[[NDArray[np.float64]], ArrayLike] | None = None
    second_derivative: Callable[[NDArray[np.float64]], ArrayLike] | None = None


LoadLike = None | float | ArrayLike | Callable[[NDArray[np.float64]], ArrayLike] | LoadHistory


@dataclass(frozen=True, eq=False)
class HarmonicResponse:
    """Two-term quasi-rigid response at ``e^{−iωt}``.

    ``acceleration``/``displacement`` ``(Nω, Nx)`` complex (m/s², m; displacement is
    ``−a/ω²``, infinite at ω = 0); ``rigid_acceleration`` ``(Nx,)``; ``epsilon`` ``(Nω,)``
    is ``(ω T_wave)² |h(ω)|`` with h the compliance-weighted creep factor (for a
    homogeneous Voigt body ``|q|² = λ²/|1 − iλβ|``, rod, or ``|q⁴|``, beam).
    """

    omega: NDArray[np.float64]
    x: NDArray[np.float64]
    acceleration: NDArray[np.complex128]
    displacement: NDArray[np.complex128]
    rigid_acceleration: NDArray[np.complex128]
    epsilon: NDArray[np.float64]
    wave_travel_time: float

    @property
    def ratio(self) -> NDArray[np.complex128]:
        """``a/a_rigid`` (the ``a*`` of docs/formulas.md §X; NaN where the rigid acceleration is 0)."""
        rigid = np.broadcast_to(self.rigid_acceleration, self.acceleration.shape)
        out = np.full(self.acceleration.shape, np.nan, dtype=complex)
        np.divide(self.acceleration, rigid, out=out, where=rigid != 0.0)
        return out


@dataclass(frozen=True, eq=False)
class TransientResponse:
    """Quasi-rigid response to end-load histories on a uniform grid.

    ``acceleration``, ``velocity``, ``displacement``: ``(Nt, Nx)`` (m/s², m/s, m; the
    displacement from the initial position and shape — the quasi-static shape under the
    initial loads — rigid motion included). ``epsilon`` is
    ``(T_wave/T_load)² |h(1/T_load)|`` at the ``load_time_scale`` used (s).
    """

    time: NDArray[np.float64]
    x: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    velocity: NDArray[np.float64]
    displacement: NDArray[np.float64]
    rigid_acceleration: NDArray[np.float64]
    epsilon: float
    load_time_scale: float
    wave_travel_time: float


class QuasiRigidBody:
    """Base of :class:`~.rod.QuasiRigidRod` and :class:`~.beam.QuasiRigidBeam` (linear in the end loads)."""

    load_names: tuple[str, ...] = ()
    order: int = 1

    def __init__(self, quadrature: BodyQuadrature, creep: CreepKernel, max_tau_groups: int) -> None:
        self.quadrature = quadrature
        self.creep = creep
        self.correction = CreepCorrection(quadrature, self.order, self._shapes, creep, max_tau_groups=max_tau_groups)
        self._coefficient_cache: dict[bytes, NDArray[np.float64]] = {}

    # -- subclass interface ----------------------------------------------------------
    def _shapes(self, s: NDArray[np.float64], S: NDArray[np.float64]) -> NDArray[np.float64]:
        raise NotImplementedError

    def rigid_modes(self, x: ArrayLike, derivative: int = 0) -> NDArray[np.float64]:
        """Rigid-body mode shapes (or their x-derivatives) at x, ``(Nx, K)``."""
        raise NotImplementedError

    @property
    def rigid_gain(self) -> NDArray[np.float64]:
        """Rigid-body accelerations per unit end load, ``(K, J)``."""
        raise NotImplementedError

    # -- common properties -----------------------------------------------------------
    @property
    def half_length(self) -> float:
        return self.quadrature.half_length

    @property
    def mass(self) -> float:
        """Total mass ``M = ∫ m dx`` (kg)."""
        return self.quadrature.total_mass

    @property
    def wave_travel_time(self) -> float:
        """``T_wave = lⁿ √(m̄ ⟨1/k⟩)`` (s): n = 1 rod, 2 beam; m̄ = M/2l, ⟨1/k⟩ the mean compliance
        (series-spring average). Homogeneous: ``l√(m/EA)`` and ``l²√(m/EI)`` as in docs/design.md §2."""
        q = self.quadrature
        return q.half_length**self.order * math.sqrt(q.mean_mass * q.mean_compliance)

    @property
    def tau_groups(self) -> NDArray[np.float64]:
        """Filter time constants (s) of the correction (0 = elastic, ∞ = rigid)."""
        return self.correction.tau_groups

    def coefficients(self, x: ArrayLike, derivative: int = 0) -> NDArray[np.float64]:
        """``C[x, j, g]`` (m per N, or per N·m) or its x-derivative, cached per probe set."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        key = bytes([derivative]) + x.tobytes()
        if key not in self._coefficient_cache:
            if len(self._coefficient_cache) > 64:
                self._coefficient_cache.clear()
            self._coefficient_cache[key] = self.correction.coefficients(x, derivative)
        return self._coefficient_cache[key]

    def creep_factor(self, omega: ArrayLike) -> NDArray[np.complex128]:
        """``h(ω) = ∫ Σᵢ kᵢ/(1 − iωτᵢ) dx/k ÷ ∫ dx/k`` (1 elastic, → 0 rigid), summed over the τ groups."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        return harmonic_factor(omega[:, None], self.tau_groups[None, :]) @ self.correction.group_compliance

    def epsilon(self, omega: ArrayLike) -> NDArray[np.float64]:
        """Small parameter ``ε(ω) = (ω T_wave)² |h(ω)|`` (docs/design.md §2 with ``T_load = 1/ω``, viscosity included)."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        return (omega * self.wave_travel_time) ** 2 * np.abs(self.creep_factor(omega))

    def epsilon_of_time_scale(self, load_time_scale: float) -> float:
        """``ε = (T_wave/T_load)² |h(1/T_load)|`` for a load time scale ``T_load`` (s); 0 for ∞: :meth:`epsilon` at
        ``ω = 1/T_load``, its sum over the τ groups in plain complex arithmetic (:func:`.creep.harmonic_factor_at`)."""
        if not load_time_scale > 0.0:
            raise ValueError("load_time_scale must be > 0")
        if math.isinf(load_time_scale):
            return 0.0
        omega = 1.0 / load_time_scale
        factor = sum(share * harmonic_factor_at(omega, tau)
                     for share, tau in zip(self.correction.group_compliance.tolist(), self.tau_groups.tolist()))
        return (omega * self.wave_travel_time) ** 2 * abs(factor)

    def _check_load_names(self, loads: Mapping[str, object]) -> None:
        unknown = set(loads) - set(self.load_names)
        if unknown:
            raise ValueError(f"unknown loads {sorted(unknown)}; this body takes {self.load_names}")

    def _load_vector(self, loads: Mapping[str, complex]) -> NDArray[np.complex128]:
        self._check_load_names(loads)
        return np.array([complex(loads.get(name, 0.0) or 0.0) for name in self.load_names])

    # -- frequency domain ------------------------------------------------------------
    def _harmonic(self, omega: ArrayLike, x: ArrayLike, loads: Mapping[str, complex], derivative: int = 0) -> HarmonicResponse:
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        x = np.atleast_1d(np.asarray(x, dtype=float))
        L = self._load_vector(loads)
        C = self.coefficients(x, derivative)                                      # (Nx, J, G)
        H = harmonic_factor(omega[:, None], self.tau_groups[None, :])            # (Nω, G)
        correction = np.einsum("xjg,j,wg->wx", C, L, H)
        rigid = self.rigid_modes(x, derivative) @ (self.rigid_gain @ L)           # (Nx,)
        acceleration = rigid[None, :] - omega[:, None] ** 2 * correction
        with np.errstate(divide="ignore", invalid="ignore"):
            displacement = np.where(omega[:, None] == 0.0, np.inf, -acceleration / np.where(omega == 0.0, 1.0, omega)[:, None] ** 2)
        return HarmonicResponse(omega, x, acceleration, displacement, rigid, self.epsilon(omega), self.wave_travel_time)

    # -- time domain -----------------------------------------------------------------
    def _transient(
        self,
        t: ArrayLike,
        x: ArrayLike,
        loads: Mapping[str, LoadLike],
        initial_velocity: ArrayLike,
        load_time_scale: float | None,
        derivative: int = 0,
    ) -> TransientResponse:
        t = np.asarray(t, dtype=float)
        x = np.atleast_1d(np.asarray(x, dtype=float))
        dt = _uniform_step(t)
        self._check_load_names(loads)
        sampled = [_sample_load(loads.get(name), t, dt) for name in self.load_names]
        value = np.stack([v for v, _, _ in sampled])                              # (J, Nt)
        # the three sequences to filter, each with a leading sample at t₀ − dt where it is 0:
        # the load change from its initial value, L̇ and L̈ (central differences or analytic)
        inputs = np.stack([np.concatenate([np.zeros((value.shape[0], 1)), value - value[:, :1]], axis=1),
                           np.stack([d1 for _, d1, _ in sampled]),
                           np.stack([d2 for _, _, d2 in sampled])])               # (3, J, Nt + 1)

        # creep correction: one recursive filter per time-constant group, O(1) per step
        from scipy.signal import lfilter  # scipy.signal costs ~0.5 s to import: only a transient response filters

        C = self.coefficients(x, derivative)
        decay, a, b = update_coefficients(dt, self.tau_groups)
        filtered = np.empty((self.tau_groups.size, *inputs.shape))
        for g in range(self.tau_groups.size):
            if decay[g] == 0.0 and b[g] == 1.0:  # τ = 0: the identity, exactly
                filtered[g] = inputs
            else:
                filtered[g] = lfilter([b[g], a[g]], [1.0, -decay[g]], inputs, axis=-1)
        Y, Z, W = np.moveaxis(filtered[..., 1:], 1, 0)                            # (G, J, Nt) each

        # rigid-body motion, exact for loads linear between samples
        gain = self.rigid_gain
        qdd = gain @ value                                                        # (K, Nt)
        qd0 = np.broadcast_to(np.asarray(initial_velocity, dtype=float), (gain.shape[0],))
        qd = qd0[:, None] + np.concatenate([np.zeros((gain.shape[0], 1)), np.cumsum(0.5 * dt * (qdd[:, 1:] + qdd[:, :-1]), axis=1)], axis=1)
        increments = dt * qd[:, :-1] + dt * dt * (2.0 * qdd[:, :-1] + qdd[:, 1:]) / 6.0
        q = np.concatenate([np.zeros((gain.shape[0], 1)), np.cumsum(increments, axis=1)], axis=1)
        modes = self.rigid_modes(x, derivative)                                   # (Nx, K)

        rigid_acceleration = (modes @ qdd).T
        acceleration = rigid_acceleration + np.einsum("gjt,xjg->tx", W, C)
        velocity = (modes @ qd).T + np.einsum("gjt,xjg->tx", Z, C)
        displacement = (modes @ q).T + np.einsum("gjt,xjg->tx", Y, C)

        if load_time_scale is None:
            load_time_scale = _load_time_scale(value, inputs[1, :, 1:])
        epsilon = self.epsilon_of_time_scale(load_time_scale)
        return TransientResponse(t, x, acceleration, velocity, displacement, rigid_acceleration, epsilon,
                                 float(load_time_scale), self.wave_travel_time)


def _uniform_step(t: NDArray[np.float64]) -> float:
    if t.ndim != 1 or t.size < 4:
        raise ValueError("the time grid must be one-dimensional with at least 4 samples")
    steps = np.diff(t)
    dt = float(steps.mean())
    if not dt > 0.0 or np.max(np.abs(steps - dt)) > 1e-6 * dt:
        raise ValueError("the time grid must be uniform and increasing")
    return dt


def _sample_load(load: LoadLike, t: NDArray[np.float64], dt: float) -> tuple[NDArray[np.float64], ...]:
    """The value ``(Nt,)`` and the first and second derivative sequences ``(Nt + 1,)`` to filter.

    The derivative sequences carry one leading sample at ``t₀ − dt``, so that the filter
    starts from rest there: central differences vanish there (the load is held before
    t₀); analytic derivatives are taken as 0 there, i.e. as ramping up over ``[t₀ − dt, t₀]``
    (O(dt) from a step at t₀; nothing when they vanish at t₀, as for a load starting smoothly).
    """
    if load is None:
        return np.zeros(t.size), np.zeros(t.size + 1), np.zeros(t.size + 1)
    first = second = None
    if isinstance(load, LoadHistory):
        value = _evaluate(load.value, t)
        if load.first_derivative is not None:
            first = _evaluate(load.first_derivative, t)
        if load.second_derivative is not None:
            second = _evaluate(load.second_derivative, t)
    elif callable(load):
        value = _evaluate(load, t)
    else:
        value = np.asarray(load, dtype=float)
        if value.ndim == 0:
            value = np.full(t.shape, float(value))
        if value.shape != t.shape:
            raise ValueError(f"a sampled load needs one value per time ({t.size}), got shape {value.shape}")
    if not np.all(np.isfinite(value)):
        raise ValueError("load samples must be finite")
    # held before t₀, quadratic extrapolation after the last sample
    ext = np.concatenate([[value[0], value[0]], value, [3.0 * value[-1] - 3.0 * value[-2] + value[-3]]])
    if first is None:
        first = (ext[2:] - ext[:-2]) / (2.0 * dt)
    else:
        first = np.concatenate([[0.0], first])
    if second is None:
        second = (ext[2:] - 2.0 * ext[1:-1] + ext[:-2]) / (dt * dt)
    else:
        second = np.concatenate([[0.0], second])
    return value, first, second


def _evaluate(f: Callable[[NDArray[np.float64]], ArrayLike], t: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.broadcast_to(np.asarray(f(t), dtype=float), t.shape).astype(float)


def _load_time_scale(value: NDArray[np.float64], first: NDArray[np.float64]) -> float:
    """``T_load = π √(Σ∫L² / Σ∫L̇²)``: the pulse length for a half-sine, ``π/ω`` for a harmonic."""
    num = float(np.sum(value**2))
    den = float(np.sum(first**2))
    if den == 0.0:
        return math.inf
    return math.pi * math.sqrt(num / den)
