"""FEM cost per time step and per frequency, as ratios measured in one run.

    python benchmarks/bench_fem.py [--quick]

For rods (P1, P2) and beams (Hermite) with 1e2 … 1e5 elements it reports
* the time per step of the stepper's loop (no energy bookkeeping, no outputs),
* the time of the bare banded triangular solves (``dpbtrs``) with the same factor,
* their ratio (target: <= 3 for >= 1e4 elements) and the per-step overhead for small meshes,
* the time per frequency of the harmonic solve.
Medians of repeated runs; nothing here is asserted.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from femref.fem import Integrator, Stepper, assemble_beam, assemble_rod, body_nodes, harmonic_response
from femref.fem.banded import BandedCholesky
from femref.core.profiles import Uniform
from femref.core.signals import HalfSine

L = 8.0


def operators(kind: str, n: int):
    nodes = body_nodes(L, n)
    if kind == "beam":
        return assemble_beam(nodes, Uniform(6250.0), Uniform(5.0e9), Uniform(1.0e7))
    return assemble_rod(nodes, 1 if kind == "rod P1" else 2, Uniform(6250.0), Uniform(2.0e9), Uniform(1.0e6))


def per_step(kind: str, n: int, steps: int, repeats: int = 3) -> tuple[float, float]:
    ops = operators(kind, n)
    loads = {"F2": HalfSine(-1e6, 0.05)} if kind != "beam" else {"N1": HalfSine(1e6, 0.05)}
    stepper = Stepper(ops, Integrator.newmark(), 1e-4, loads)
    loop = []
    for _ in range(repeats):
        states = stepper.iterate(steps + 1)
        next(states)  # initial state (consistent acceleration)
        next(states)  # first step: pays the set-up (factorisation of S, history matrices)
        started = time.perf_counter()
        for _state in states:
            pass
        loop.append((time.perf_counter() - started) / steps)
    factor = BandedCholesky((ops.mass + 1e-8 * ops.stiffness).tocsr())
    rhs = np.random.default_rng(0).standard_normal(ops.ndof)
    solves = []
    for _ in range(repeats):
        started = time.perf_counter()
        for _ in range(steps):
            factor.solve(rhs)
        solves.append((time.perf_counter() - started) / steps)
    return statistics.median(loop), statistics.median(solves)


def per_frequency(kind: str, n: int, count: int = 5) -> float:
    ops = operators(kind, n)
    omega = np.linspace(10.0, 500.0, count)
    loads = {"F2": 1.0} if kind != "beam" else {"N1": 1.0}
    started = time.perf_counter()
    harmonic_response(ops, omega, loads, np.array([0.0]))
    return (time.perf_counter() - started) / count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer sizes and steps")
    args = parser.parse_args()
    sizes = [100, 1000, 10_000] if args.quick else [100, 1000, 10_000, 100_000]
    print(f"{'body':8s} {'elements':>9s} {'dofs':>8s} {'step µs':>9s} {'solve µs':>9s} {'ratio':>6s} {'freq ms':>8s}")
    for kind in ("rod P1", "rod P2", "beam"):
        for n in sizes:
            steps = max(100, min(2000, 2_000_000 // n))
            step, solve = per_step(kind, n, steps)
            freq = per_frequency(kind, n)
            ndof = operators(kind, n).ndof if n <= 1000 else {"rod P1": n + 1, "rod P2": 2 * n + 1, "beam": 2 * n + 2}[kind]
            print(f"{kind:8s} {n:9d} {ndof:8d} {1e6 * step:9.1f} {1e6 * solve:9.1f} {step / solve:6.2f} {1e3 * freq:8.2f}")


if __name__ == "__main__":
    main()
