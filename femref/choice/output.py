"""A model choice in the result file (``/choice``, its layout: docs/design.md §4.3) and on the terminal."""

from __future__ import annotations

import math

import h5py
import numpy as np
from rich.table import Table

from femref.choice.choose import ModelChoice, RungEstimate
from femref.choice.estimates import OUTPUTS
from femref.core.catalog import CHOICE_GROUP

__all__ = ["choice_table", "write_choice"]


def write_choice(h5: h5py.File, choice: ModelChoice) -> None:
    """The ``/choice`` group (module docstring)."""
    group = h5.create_group(CHOICE_GROUP)
    chosen = choice.chosen_row
    group.attrs.update(tolerance=choice.tolerance, output=choice.output, output_description=OUTPUTS[choice.output], chosen=choice.chosen,
                       met=bool(choice.met), estimate=chosen.estimate, basis=chosen.basis, epsilon_load=choice.epsilon_load)
    rows = choice.rows
    strings = {
        "label": [row.rung.label for row in rows],
        "family": [row.rung.family for row in rows],
        "basis": [row.basis for row in rows],
        "status": [row.result.status if row.result is not None else "" for row in rows],
    }
    for name, values in strings.items():
        group.create_dataset(name, data=np.array(values, dtype=h5py.string_dtype()))
    group.create_dataset("resolution", data=np.array([row.rung.resolution for row in rows], dtype=np.int64))
    group.create_dataset("predicted_cost", data=np.array([row.rung.cost for row in rows])).attrs["units"] = "µs (fitting machine)"
    group.create_dataset("dt", data=np.array([row.rung.dt for row in rows])).attrs["units"] = "s"
    group.create_dataset("ran", data=np.array([row.ran for row in rows], dtype=bool))
    group.create_dataset("wall_time_s", data=np.array([row.result.wall_time_s if row.ran else math.nan for row in rows])).attrs["units"] = "s"
    group.create_dataset("peak_coupler_force", data=np.array([_peak(row) for row in rows])).attrs["units"] = "N"
    group.create_dataset("estimate", data=np.array([row.estimate for row in rows]))


def _peak(row: RungEstimate) -> float:
    if not row.ran:
        return math.nan
    return max(float(np.max(out["force"])) for out in row.result.couplers.values())


def choice_table(choice: ModelChoice) -> Table:
    """Every rung: predicted cost (ms on the machine that fitted the model), wall time, peak force, estimate
    and its basis; the choice marked."""
    verdict = "within" if choice.met else "NOT within (no rung is expected to be; the most accurate is kept)"
    title = (
        f"model choice: {choice.chosen} is expected {verdict} {choice.tolerance:.3g} on {choice.output} "
        f"(estimate {choice.chosen_row.estimate:.2g}); ε_load = {choice.epsilon_load:.3g}"
    )
    table = Table(title=title, title_justify="left")
    for column in ("", "rung", "predicted cost", "wall time", "peak P kN", "estimate", "basis"):
        table.add_column(column, justify="left" if column in ("", "rung", "basis") else "right")
    for row in choice.rows:
        table.add_row(
            "→" if row.rung.label == choice.chosen else "",
            row.rung.label,
            f"{row.rung.cost * 1e-3:.1f} ms",
            f"{row.result.wall_time_s * 1e3:.1f} ms" if row.result is not None else "",
            f"{_peak(row) / 1e3:.1f}" if row.ran else "",
            f"{row.estimate:.2g}" if math.isfinite(row.estimate) else "",
            row.basis,
        )
    return table
