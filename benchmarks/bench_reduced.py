"""Cost of the quasi-rigid models, as ratios measured in one run.

    python benchmarks/bench_reduced.py [--quick]

Reports
* the quasi-rigid time-domain cost per step at Nt = 1e3, 1e4, 1e5 — the vectorised
  ``transient()`` (one recursive filter per load and time-constant group through
  ``scipy.signal.lfilter``) and the ``stepper().step()`` loop of the displacement form —
  and the ratio of the largest to the smallest (O(1) per step means ≈ 1; the vectorised
  path carries a fixed per-call overhead that shows at small Nt);
* the cost per call of each reduced model relative to the rigid closed form
  ``reduced.rigid.kelvin_voigt_impact`` on the same number of samples.
Body set-up (profile integrals by quadrature) is timed separately: it is paid once per body.
Medians of repeated runs; nothing here is asserted.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from reduced.quasi_rigid import QuasiRigidBeam, QuasiRigidRod
from reduced.rigid import ImpactPair, kelvin_voigt_impact

L = 8.0
M, EA, EI = 6250.0, 2.0e9, 5.0e9
CA = 0.3 * L * np.sqrt(M * EA)
CI = 0.3 * L**2 * np.sqrt(M * EI)
T_WAVE = L * np.sqrt(M / EA)


def median_time(function, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def profiled_rod(viscosity: float = CA) -> QuasiRigidRod:
    """Two-value density and a viscosity jump: two exact time-constant groups."""
    return QuasiRigidRod(L, lambda x: np.where(np.abs(x) < L / 2, 2 * M, M), EA,
                         lambda x: np.where(np.abs(x) < L / 2, 2 * viscosity, viscosity), jumps=[-L / 2, L / 2])


def load(t: np.ndarray) -> np.ndarray:
    duration = 0.2
    return 1e6 * np.sin(np.pi * t / duration) * (t < duration)


def per_step_costs(sizes: list[int], repeats: int) -> list[tuple[int, float, float]]:
    rod = profiled_rod()
    rows = []
    for n in sizes:
        t = np.linspace(0.0, 0.5, n)
        F2 = load(t)
        rod.transient(t, [-L, 0.0, L], F2=F2)  # warm-up; probe coefficients are cached per body
        vectorised_repeats = max(repeats, min(200, 200_000 // n))
        vectorised = median_time(lambda: rod.transient(t, [-L, 0.0, L], F2=F2), vectorised_repeats) / n
        stepper_repeats = max(1, min(repeats, 100_000 // n))
        dt = t[1] - t[0]

        def loop() -> None:
            stepper = rod.stepper([0.0])
            for k in range(1, n):
                stepper.step(dt, 0.0, F2[k])

        stepped = median_time(loop, stepper_repeats) / (n - 1)
        rows.append((n, vectorised, stepped))
    return rows


def coupled_impact(hammer: QuasiRigidRod, anvil: QuasiRigidRod, n: int, dt: float) -> None:
    """Two quasi-rigid cars and a linear Kelvin–Voigt coupler, force solved from the affine step predictions."""
    k, c = 4.0e7, 3.0e5
    sh, sa = hammer.stepper(initial_rigid_velocity=2.0), anvil.stepper()
    for _ in range(n):
        ph, pa = sh.predict(dt), sa.predict(dt)
        d0 = ph.displacement[1] - pa.displacement[0]
        d1 = -ph.displacement_gain[1, 1] + pa.displacement_gain[0, 0]
        v0 = ph.velocity[1] - pa.velocity[0]
        v1 = -ph.velocity_gain[1, 1] + pa.velocity_gain[0, 0]
        P = (k * d0 + c * v0) / (1.0 - k * d1 - c * v1)
        sh.step(dt, 0.0, -P)
        sa.step(dt, -P, 0.0)


def per_call_costs(n: int, repeats: int) -> list[tuple[str, float]]:
    t = np.linspace(0.0, 0.5, n)
    F2 = load(t)
    pair = ImpactPair(2 * L * M, 2 * L * M, 2.0)
    rod, beam = profiled_rod(), QuasiRigidBeam(L, M, EI, CI)
    x = [-L, 0.0, L]
    omega = np.linspace(1.0, 200.0, n)
    rod.transient(t[:8], x, F2=F2[:8])
    beam.transient(t[:8], x, N1=F2[:8])
    rows = [
        ("rigid closed form (kelvin_voigt_impact)", median_time(lambda: kelvin_voigt_impact(pair, 4.0e7, 3.0e5, t), repeats)),
        ("quasi-rigid rod transient, 3 probes", median_time(lambda: rod.transient(t, x, F2=F2), repeats)),
        ("quasi-rigid beam transient, 3 probes", median_time(lambda: beam.transient(t, x, N1=F2), repeats)),
        ("quasi-rigid rod harmonic, Nω = Nt, 3 probes", median_time(lambda: rod.harmonic(omega, x, F2=1.0), repeats)),
        ("quasi-rigid beam harmonic, Nω = Nt, 3 probes", median_time(lambda: beam.harmonic(omega, x, N1=1.0), repeats)),
        ("quasi-rigid stepper (one car), Nt steps", median_time(lambda: _stepper_run(rod, F2, t[1] - t[0]), max(1, repeats // 3))),
        ("quasi-rigid coupled impact (two cars + coupler), Nt steps",
         median_time(lambda: coupled_impact(rod, profiled_rod(), n, t[1] - t[0]), max(1, repeats // 3))),
        ("set-up: QuasiRigidRod(...) profile integrals (once per body)", median_time(profiled_rod, repeats)),
        ("set-up: probe coefficients for 3 new probes", median_time(lambda: rod.correction.coefficients(x), repeats)),
    ]
    return rows


def _stepper_run(rod: QuasiRigidRod, F2: np.ndarray, dt: float) -> None:
    stepper = rod.stepper()
    for k in range(1, F2.size):
        stepper.step(dt, 0.0, F2[k])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    args = parser.parse_args()
    repeats = 3 if args.quick else 7

    rows = per_step_costs([1_000, 10_000, 100_000], repeats)
    print("Quasi-rigid time-domain cost per step (two time-constant groups, 3 probes)")
    print(f"{'Nt':>8} {'transient() µs/step':>20} {'stepper µs/step':>16}")
    for n, vectorised, stepped in rows:
        print(f"{n:>8d} {vectorised * 1e6:>20.3f} {stepped * 1e6:>16.2f}")
    v = [r[1] for r in rows]
    s = [r[2] for r in rows]
    print(f"{'max/min':>8} {max(v) / min(v):>20.2f} {max(s) / min(s):>16.2f}")

    n = 10_000
    rows = per_call_costs(n, repeats)
    base = rows[0][1]
    print(f"\nCost per call, Nt = {n} samples, relative to the rigid closed form")
    print(f"{'model':<62} {'ms/call':>10} {'ratio':>10}")
    for name, seconds in rows:
        print(f"{name:<62} {seconds * 1e3:>10.3f} {seconds / base:>10.1f}")


if __name__ == "__main__":
    main()
