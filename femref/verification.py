"""The verification figures a reviewer asks for, regenerated from the code (``femref figures``).

Each figure function computes its data with femref's own solvers, draws it with
matplotlib (Agg) and returns the numbers it shows, so the test suite can assert what
the pictures claim (``tests/verification/test_verification.py``):

* :func:`fem_convergence` — harmonic FEM error against the exact closed forms versus the
  element count: rod P1 (order 2), rod P2 (order 4), beam Hermite (order 4, deflection);
  the observed orders are fitted and printed in the legend.
* :func:`harmonic_against_exact` — the classic figure: Re and Im of the normalised centre
  acceleration ``a(0)/a_rigid`` of a free Voigt rod (end force F2) or beam (end shears N1 = −N2),
  versus ``λ = ω T`` at ``β = 0.1, 1, 5``: exact solid, quasi-rigid dashed, FEM markers.
* :func:`quasi_rigid_epsilon` — the quasi-rigid rod's time-domain error for a Gaussian end
  force against the exact (FFT synthesis of the exact harmonic response) versus
  ``ε = (T_wave/T_load)²``, with its fitted slope (≈ 2).

Body: l = 8 m, m = 6250 kg/m, EA = 2 GN (rod), EI = 20 GN·m² (beam);
``T = l√(m/EA)`` (rod), ``l²√(m/EI)`` (beam); β = cA/(l √(m EA)), cI/(l² √(m EI)).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from femref.exact import Segments, beam_harmonic, rod_harmonic
from femref.fem import assemble_beam, assemble_rod, body_nodes, harmonic_response
from femref.core.profiles import Uniform

L, MASS, EA, EI = 8.0, 6250.0, 2.0e9, 2.0e10
T_ROD, T_BEAM = L * np.sqrt(MASS / EA), L**2 * np.sqrt(MASS / EI)
BETAS = (0.1, 1.0, 5.0)


@dataclass(frozen=True)
class Figure:
    """A drawn figure (PNG bytes) and the numbers it claims, by name."""

    name: str
    png: bytes
    numbers: dict[str, float]


def observed_order(elements: NDArray, errors: NDArray) -> float:
    """``−d log e / d log n`` fitted over the points (least squares)."""
    return float(-np.polyfit(np.log(elements), np.log(errors), 1)[0])


def _rod(beta: float, elements: int, order: int):
    c = beta * L * np.sqrt(MASS * EA)
    return assemble_rod(body_nodes(L, elements), order, Uniform(MASS), Uniform(EA), Uniform(c)), Segments.uniform(2 * L, MASS, EA, c)


def _beam(beta: float, elements: int):
    c = beta * L**2 * np.sqrt(MASS * EI)
    return assemble_beam(body_nodes(L, elements), Uniform(MASS), Uniform(EI), Uniform(c)), Segments.uniform(2 * L, MASS, EI, c)


def convergence_errors(kind: str, elements: NDArray, lam: float = 3.0, beta: float = 0.1) -> NDArray[np.float64]:
    """Max relative displacement error over five points at ``λ`` for ``kind`` in rod_p1, rod_p2, beam."""
    x = np.array([-L, -3.0, 0.0, 5.0, L])
    errors = []
    for n in elements:
        if kind == "beam":
            ops, seg = _beam(beta, int(n))
            omega, loads, exact = np.array([lam / T_BEAM]), {"N1": 1.0, "N2": -0.5}, beam_harmonic
        else:
            ops, seg = _rod(beta, int(n), 1 if kind == "rod_p1" else 2)
            omega, loads, exact = np.array([lam / T_ROD]), {"F1": 0.4, "F2": -1.0}, rod_harmonic
        fem = harmonic_response(ops, omega, loads, x).displacement
        solution = exact(seg, omega, x, **loads)
        reference = solution.deflection if kind == "beam" else solution.displacement
        errors.append(np.max(np.abs(fem - reference)) / np.max(np.abs(reference)))
    return np.array(errors)


def fem_convergence() -> Figure:
    """Rod P1/P2 and beam Hermite errors against the exact solution versus elements, with fitted orders."""
    import matplotlib.pyplot as plt

    runs = {"rod_p1": np.array([8, 16, 32, 64, 128]), "rod_p2": np.array([4, 8, 16, 32]), "beam": np.array([4, 8, 16, 32])}
    labels = {"rod_p1": "rod, P1", "rod_p2": "rod, P2", "beam": "beam, Hermite cubic"}
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    numbers = {}
    for kind, elements in runs.items():
        errors = convergence_errors(kind, elements)
        numbers[f"order_{kind}"] = observed_order(elements, errors)
        ax.loglog(elements, errors, "o-", label=f"{labels[kind]}: order {numbers[f'order_{kind}']:.2f}")
    ax.set(xlabel="elements over the body", ylabel="max relative displacement error", title="Harmonic FEM vs exact (λ = 3, β = 0.1)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return Figure("fem_convergence", _png(fig), numbers)


def harmonic_against_exact(body: str) -> Figure:
    """Re and Im of ``a(0)/a_rigid`` versus λ at β = 0.1, 1, 5: exact, quasi-rigid, FEM (``body`` rod or beam).

    ``a_rigid = F/M`` is the rigid-body acceleration of the same loads (the λ → 0 limit):
    ``F2`` at +l for the rod, symmetric end shears ``N1 = −N2`` for the beam.
    """
    import matplotlib.pyplot as plt

    from reduced.quasi_rigid import QuasiRigidBeam, QuasiRigidRod

    lambdas = np.linspace(0.05, 3.0, 60)
    marks = lambdas[::6]
    x = np.array([0.0])
    fig, (re_ax, im_ax) = plt.subplots(1, 2, figsize=(11, 4.4))
    numbers = {}
    for k, beta in enumerate(BETAS):
        colour = f"C{k}"
        if body == "rod":
            ops, seg = _rod(beta, 32, 2)
            T, loads, exact = T_ROD, {"F2": 1.0}, rod_harmonic
            model = QuasiRigidRod(L, MASS, EA, beta * L * np.sqrt(MASS * EA))
        else:
            ops, seg = _beam(beta, 32)
            T, loads, exact = T_BEAM, {"N1": 0.5, "N2": -0.5}, beam_harmonic
            model = QuasiRigidBeam(L, MASS, EI, beta * L**2 * np.sqrt(MASS * EI))
        scale = 1.0 / model.harmonic(np.array([1e-6 / T]), x, **loads).acceleration[0, 0]  # 1/a_rigid = M/F
        a_exact = exact(seg, lambdas / T, x, **loads).acceleration[:, 0] * scale
        a_model = model.harmonic(lambdas / T, x, **loads).acceleration[:, 0] * scale
        a_fem = harmonic_response(ops, marks / T, loads, x).acceleration[:, 0] * scale
        low = lambdas <= 0.5
        numbers[f"quasi_rigid_error_lambda_0.5_beta_{beta:g}"] = float(np.max(np.abs(a_model[low] - a_exact[low])) / np.max(np.abs(a_exact[low])))
        numbers[f"fem_error_beta_{beta:g}"] = float(np.max(np.abs(a_fem - a_exact[::6])) / np.max(np.abs(a_exact)))
        for ax, part in ((re_ax, np.real), (im_ax, np.imag)):
            ax.plot(lambdas, part(a_exact), "-", color=colour, label=f"β = {beta:g}, exact")
            ax.plot(lambdas, part(a_model), "--", color=colour, label=f"β = {beta:g}, quasi-rigid")
            ax.plot(marks, part(a_fem), "o", color=colour, mfc="none", label=f"β = {beta:g}, FEM (32 el.)")
    what = "rod, end force F2" if body == "rod" else "beam, end shears N1 = −N2"
    for ax, part in ((re_ax, "Re"), (im_ax, "Im")):
        ax.set(xlabel="λ = ω T", ylabel=f"{part} a(0) / a_rigid")
        ax.grid(True, alpha=0.3)
    re_ax.set_title(f"{what}: centre acceleration, Re")
    im_ax.set_title("Im")
    im_ax.legend(fontsize=7, ncol=1, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.tight_layout()
    return Figure(f"harmonic_{body}", _png(fig), numbers)


def quasi_rigid_epsilon() -> Figure:
    """Quasi-rigid rod (β = 0.3) under a Gaussian end force: max acceleration error vs ε, fitted slope."""
    import matplotlib.pyplot as plt

    from reduced.quasi_rigid import QuasiRigidRod
    from reduced.quasi_rigid import LoadHistory

    c = 0.3 * L * np.sqrt(MASS * EA)
    segments, rod = Segments.uniform(2 * L, MASS, EA, c), QuasiRigidRod(L, MASS, EA, c)
    x = np.array([-L, 0.0, L])
    epsilons, errors = [], []
    for eps in (0.01, 0.003, 0.001, 3e-4):
        sigma = T_ROD / (np.pi * np.sqrt(eps))
        centre = 6 * sigma

        def value(t, sigma=sigma, centre=centre):
            return np.exp(-(((t - centre) / sigma) ** 2))

        load = LoadHistory(
            value,
            lambda t, s=sigma, c0=centre, v=value: v(t) * (-2 * (t - c0) / s**2),
            lambda t, s=sigma, c0=centre, v=value: v(t) * (4 * (t - c0) ** 2 / s**4 - 2 / s**2),
        )
        period = 12 * sigma + 80 * T_ROD
        n = int(2 ** np.ceil(np.log2(period / (T_ROD / 40))))
        t = np.arange(n) * period / n
        omega = 2 * np.pi * np.fft.fftfreq(n, d=period / n)
        H = np.empty((n, x.size), dtype=complex)
        H[omega > 0] = rod_harmonic(segments, omega[omega > 0], x, F2=1.0).acceleration
        H[omega < 0] = np.conj(rod_harmonic(segments, -omega[omega < 0], x, F2=1.0).acceleration)
        H[omega == 0] = 1.0 / rod.mass
        exact = np.fft.fft(np.fft.ifft(value(t))[:, None] * H, axis=0).real
        keep = t < 12 * sigma
        model = rod.transient(t[keep], x, F2=load)
        epsilons.append(model.epsilon)
        errors.append(np.max(np.abs(model.acceleration - exact[keep])) * rod.mass)
    slope = -observed_order(np.array(epsilons), np.array(errors))
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    ax.loglog(epsilons, errors, "o-", label=f"quasi-rigid rod, β = 0.3: slope {slope:.2f}")
    ax.loglog(epsilons, errors[-1] * (np.array(epsilons) / epsilons[-1]) ** 2, "k:", label="ε²")
    ax.set(xlabel="ε = (T_wave / T_load)²", ylabel="max |a − a_exact| · M / A", title="Quasi-rigid rod vs exact, Gaussian end force")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return Figure("quasi_rigid_epsilon", _png(fig), {"slope": slope})


FIGURES: tuple[tuple[str, Callable[[], Figure]], ...] = (
    ("fem_convergence", lambda: fem_convergence()),
    ("harmonic_rod", lambda: harmonic_against_exact("rod")),
    ("harmonic_beam", lambda: harmonic_against_exact("beam")),
    ("quasi_rigid_epsilon", lambda: quasi_rigid_epsilon()),
)
"""Every verification figure: its name (the PNG's stem) and the call that makes it (looked up when called)."""


def all_figures() -> list[Figure]:
    """Every figure of :data:`FIGURES`, made in order."""
    return [make() for _, make in FIGURES]


def _png(fig) -> bytes:
    import io

    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buffer.getvalue()


__all__ = ["FIGURES", "Figure", "all_figures", "fem_convergence", "harmonic_against_exact", "quasi_rigid_epsilon"]
