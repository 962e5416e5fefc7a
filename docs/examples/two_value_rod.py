"""Two-value density and two-value viscosity rods: corrected and printed asymptotics against exact and FEM (source Figs 4.5–4.6).

docs/formulas.md §D.8–D.9 (free Voigt rod on [−l, l], end force F2 at +l, centre response
a* = M a(0)/F2, factor e^{−iωt}, λ = ωl√(m̄/EA) with the mean mass m̄)::

    two-value density (m1 for |x| > l/2, m2 inside, r = m2/m1):
        corrected  a* = 1 + (r² + 6r + 1) λ² / (12 (1 + r)² (1 − iλβ))
        printed    a* = 1 + (7 + r²) λ² / (12 (1 + r)² (1 − iλβ))          error O(λ²) unless r = 1
    two-value viscosity (β1 for |x| > l/2, β2 inside):
        corrected  a* = 1 + (λ²/12) (1/(1 − iλβ1) + 1/(1 − iλβ2))
        printed    a* = 1 + λ² (7/(48 (1 − iλβ1)) + 1/(48 (1 − iλβ2)))
                   error = (λ²/16)(1/(1 − iλβ1) − 1/(1 − iλβ2)) = O(λ³ (β1 − β2))

Source: Figs 4.5–4.6 plotted the printed forms over λ (curves only). The printed density
numerator 7 + r² and viscosity weights 7/48, 1/48 are misprints (docs/formulas.md, table of
corrections); the printed weights are taken here with 7/48 on the outer β1 and 1/48 on the
inner β2 (their sum 1/6 keeps the homogeneous limit; either assignment errs at O(λ³)).

Here: the exact transfer-matrix solution (``femref.exact.rod_harmonic``) and the FEM (64 P2
elements with nodes on the jumps, ``femref.fem.harmonic_response``) of the same bodies,
l = 8 m, m̄ = 6250 kg/m, EA = 2 GN; density r = 0.25 and 4 at β = 0.3; viscosity β1 = 0.2,
β2 = 3. The corrected forms are what ``reduced.quasi_rigid.QuasiRigidRod`` reproduces
(tests/reduced/quasi_rigid/test_frequency.py); they are written out here as the formulas.

Headline: observed error orders over λ = 0.01–0.1 — corrected density 4.00 (both r),
printed density 2.00; corrected viscosity 3.98, printed viscosity 2.98 (not 2: its weights
sum to the right 1/6). At λ = 0.3 the corrected forms err by 1.0e-4 and 1.1e-4, the printed
density by 2.1e-2 (r = 0.25) and 5.5e-3 (r = 4), the printed viscosity by 3.5e-3. FEM and
exact agree to 5e-9.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from femref.core.profiles import Piecewise, Uniform
from femref.exact import Segments, rod_harmonic
from femref.fem import assemble_rod, body_nodes, harmonic_response

HALF_LENGTH, MEAN_MASS, AXIAL_STIFFNESS = 8.0, 6250.0, 2.0e9  # m, kg/m, N
WAVE_TIME = HALF_LENGTH * np.sqrt(MEAN_MASS / AXIAL_STIFFNESS)  # s: λ = ω · WAVE_TIME (mean mass)
EDGES = np.array([-HALF_LENGTH, -HALF_LENGTH / 2, HALF_LENGTH / 2, HALF_LENGTH])
DENSITY_RATIOS = (0.25, 4.0)
DENSITY_BETA = 0.3
VISCOSITY_BETAS = (0.2, 3.0)  # β1 outside, β2 inside
ELEMENTS = 64
LAMBDAS = np.geomspace(0.01, 1.5, 60)  # the figure's axis
ORDER_LAMBDAS = np.geomspace(0.01, 0.1, 8)


def viscosity_of(beta: float) -> float:
    """``cA = β l √(m̄ EA)`` (N·s)."""
    return beta * HALF_LENGTH * np.sqrt(MEAN_MASS * AXIAL_STIFFNESS)


def density_body(r: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Segment masses (m1, r m1, m1) with mean ``MEAN_MASS`` and viscosities (all at ``DENSITY_BETA``)."""
    m1 = 2.0 * MEAN_MASS / (1.0 + r)
    return np.array([m1, r * m1, m1]), np.full(3, viscosity_of(DENSITY_BETA))


def viscosity_body() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    b1, b2 = VISCOSITY_BETAS
    return np.full(3, MEAN_MASS), np.array([viscosity_of(b1), viscosity_of(b2), viscosity_of(b1)])


def exact_ratio(mass: NDArray[np.float64], viscosity: NDArray[np.float64], lam: NDArray[np.float64]) -> NDArray[np.complex128]:
    """``a* = M a(0)/F2`` from the exact transfer-matrix solution."""
    body = Segments(EDGES, mass, np.full(3, AXIAL_STIFFNESS), viscosity)
    return body.mass * rod_harmonic(body, lam / WAVE_TIME, [0.0], 0.0, 1.0).acceleration[:, 0]


def fem_ratio(mass: NDArray[np.float64], viscosity: NDArray[np.float64], lam: NDArray[np.float64]) -> NDArray[np.complex128]:
    """``a* = M a(0)/F2`` from the FEM (P2, nodes on the jumps at ±l/2)."""
    jumps = (EDGES[1], EDGES[2])
    ops = assemble_rod(body_nodes(HALF_LENGTH, ELEMENTS, jumps=jumps), 2, Piecewise(jumps, tuple(mass)),
                       Uniform(AXIAL_STIFFNESS), Piecewise(jumps, tuple(viscosity)))
    total_mass = float(np.sum(mass * np.diff(EDGES)))
    return total_mass * harmonic_response(ops, lam / WAVE_TIME, {"F2": 1.0}, np.array([0.0])).acceleration[:, 0]


def density_corrected(r: float, lam: NDArray[np.float64]) -> NDArray[np.complex128]:
    return 1 + (r * r + 6 * r + 1) * lam**2 / (12 * (1 + r) ** 2 * (1 - 1j * lam * DENSITY_BETA))


def density_printed(r: float, lam: NDArray[np.float64]) -> NDArray[np.complex128]:
    return 1 + (7 + r * r) * lam**2 / (12 * (1 + r) ** 2 * (1 - 1j * lam * DENSITY_BETA))


def viscosity_corrected(lam: NDArray[np.float64]) -> NDArray[np.complex128]:
    b1, b2 = VISCOSITY_BETAS
    return 1 + lam**2 / 12 * (1 / (1 - 1j * lam * b1) + 1 / (1 - 1j * lam * b2))


def viscosity_printed(lam: NDArray[np.float64]) -> NDArray[np.complex128]:
    b1, b2 = VISCOSITY_BETAS
    return 1 + lam**2 * (7 / (48 * (1 - 1j * lam * b1)) + 1 / (48 * (1 - 1j * lam * b2)))


def observed_order(lam: NDArray[np.float64], error: NDArray[np.float64]) -> float:
    """Least-squares slope of log |error| against log λ."""
    return float(np.polyfit(np.log(lam), np.log(np.abs(error)), 1)[0])


FORMS = {
    **{f"density_r{r:g}": (density_body(r), lambda lam, r=r: density_corrected(r, lam),
                            lambda lam, r=r: density_printed(r, lam)) for r in DENSITY_RATIOS},
    "viscosity": (viscosity_body(), viscosity_corrected, viscosity_printed),
}
TITLES = {
    **{f"density_r{r:g}": f"Fig. 4.5: two-value density, r = {r:g}, β = {DENSITY_BETA:g}" for r in DENSITY_RATIOS},
    "viscosity": f"Fig. 4.6: two-value viscosity, β1 = {VISCOSITY_BETAS[0]:g}, β2 = {VISCOSITY_BETAS[1]:g}",
}
exact = {name: exact_ratio(*body, LAMBDAS) for name, (body, _, _) in FORMS.items()}
fem = {name: fem_ratio(*body, LAMBDAS) for name, (body, _, _) in FORMS.items()}
fem_error = {name: float(np.max(np.abs(fem[name] - exact[name]))) for name in FORMS}
order_corrected, order_printed, error_at_03_corrected, error_at_03_printed = {}, {}, {}, {}
for name, (body, corrected, printed) in FORMS.items():
    reference = exact_ratio(*body, ORDER_LAMBDAS)
    order_corrected[name] = observed_order(ORDER_LAMBDAS, corrected(ORDER_LAMBDAS) - reference)
    order_printed[name] = observed_order(ORDER_LAMBDAS, printed(ORDER_LAMBDAS) - reference)
    at = np.array([0.3])
    error_at_03_corrected[name] = float(np.abs(corrected(at) - exact_ratio(*body, at))[0])
    error_at_03_printed[name] = float(np.abs(printed(at) - exact_ratio(*body, at))[0])

headline = {
    **{f"order_corrected_{name}": v for name, v in order_corrected.items()},
    **{f"order_printed_{name}": v for name, v in order_printed.items()},
}


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(15, 7.5))
    for column, (name, (body, corrected, printed)) in enumerate(FORMS.items()):
        top, bottom = axes[0, column], axes[1, column]
        top.plot(LAMBDAS, exact[name].real, "k", label="exact Re")
        top.plot(LAMBDAS, exact[name].imag, "k", alpha=0.5, label="exact Im")
        top.plot(LAMBDAS[::6], fem[name][::6].real, "ko", mfc="none", ms=4, label="FEM")
        top.plot(LAMBDAS[::6], fem[name][::6].imag, "ko", mfc="none", ms=4, alpha=0.5)
        top.plot(LAMBDAS, corrected(LAMBDAS).real, "--", color="tab:blue", label="corrected")
        top.plot(LAMBDAS, corrected(LAMBDAS).imag, "--", color="tab:blue", alpha=0.5)
        top.plot(LAMBDAS, printed(LAMBDAS).real, ":", color="tab:red", label="printed")
        top.plot(LAMBDAS, printed(LAMBDAS).imag, ":", color="tab:red", alpha=0.5)
        top.set(title=TITLES[name], xlabel="λ", ylabel="a* = M a(0)/F2")
        top.legend(fontsize=8)
        bottom.loglog(LAMBDAS, np.abs(corrected(LAMBDAS) - exact[name]), color="tab:blue",
                      label=f"corrected, order {order_corrected[name]:.2f}")
        bottom.loglog(LAMBDAS, np.abs(printed(LAMBDAS) - exact[name]), color="tab:red",
                      label=f"printed, order {order_printed[name]:.2f}")
        bottom.set(xlabel="λ", ylabel="|a*_form − a*_exact|")
        bottom.legend(fontsize=8)
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    fig.tight_layout()
    out = Path(__file__).with_name("figures") / "two_value_rod.png"
    out.parent.mkdir(exist_ok=True)
    fig.savefig(out, dpi=110)
    for key, value in headline.items():
        print(f"{key}: {value:.4g}")
