"""Which coupler forces of a line the kalman estimator can observe from the instrumented cars' accelerations.

An accelerometer sees no constant force that leaves its car balanced: at the random walks' eigenvalue λ = 0 the
forces ``P`` unseen are those with ``P_{i−1} = P_i`` on every instrumented car ``i`` (its rigid acceleration
``(P_{i−1} − P_i)/M_i``; its static deformation gives no acceleration), a coupler the line does not have counting
as ``P = 0``. So the couplers joined through instrumented cars form a stretch carrying one common steady force,
seen only when the stretch ends at an instrumented car with no further coupler (that car's single force is its
acceleration); a stretch whose two end cars carry no recorded sensor is unobservable, every coupler of it. Any
other coupler is felt, with its own dynamics, by an instrumented neighbour. This is the PBH test of
:func:`reduced.kalman.undetectable_couplers` at λ = 0, decided from the layout alone (tests check both agree).
"""

from __future__ import annotations

from collections.abc import Sequence


def unobservable_couplers(cars: Sequence[str], instrumented: Sequence[bool], rears: Sequence[int], names: Sequence[str]) -> dict[str, str]:
    """Coupler name → why its force cannot be observed, for couplers ``names`` between car ``rears[j]`` and the next
    of the line ``cars``, each car ``instrumented`` or not (module docstring)."""
    by_rear = {rear: j for j, rear in enumerate(rears)}
    refused: dict[str, str] = {}
    for j, rear in enumerate(rears):
        if names[j] in refused:
            continue
        stretch, first, last = [j], rear, rear + 1
        while instrumented[first] and first - 1 in by_rear:
            first -= 1
            stretch.insert(0, by_rear[first])
        while instrumented[last] and last in by_rear:
            stretch.append(by_rear[last])
            last += 1
        if instrumented[first] or instrumented[last]:
            continue
        ends = f"cars {cars[first]} and {cars[last]} carry no sensors"
        for k in stretch:
            if len(stretch) == 1:
                refused[names[k]] = f"no instrumented car feels its force: {ends}"
            else:
                others = ", ".join(names[m] for m in stretch if m != k)
                between = ", ".join(cars[i] for i in range(first + 1, last))
                refused[names[k]] = (f"a steady force through it and {others} at once accelerates no instrumented car "
                                     f"({between} squeezed from both ends): {ends}; record one of them")
    return refused


__all__ = ["unobservable_couplers"]
