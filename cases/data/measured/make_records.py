"""Write the records of ``cases/measured_yard.yaml``: a simulated stream with two yard impacts.

Not a real recording: two impacts of the default scene's hoppers (``femref.case.defaults``),
at 2.2 m/s (the gear stays open) and at 4.0 m/s with a softer gear damper (the gear goes
solid), run with femref's fem model and recorded through the default scene's measurement
chain (1 kHz, 100 Hz anti-alias filter, 0.05 m/s² noise). Each car's recorder writes its own
CSV file: the hammer's in g with a 0.02 m/s² offset, the anvil's in mm/s² on a clock 4 ms
behind (the case's ``clock_offset`` puts it back); 1.5 s of noise between and around the
impacts. ``python cases/data/measured/make_records.py`` rewrites both files (seeded).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from femref.case import parse_case
from femref.case.defaults import default_scene_data
from femref.run.runner import run_scene
from femref.scene.build import scene_from_case

HERE = Path(__file__).parent
QUIET = 1.5  # s of noise before, between and after the impacts
ANVIL_CLOCK = -0.004  # s: the anvil recorder's clock lags


def impact(speed: float, gear_damping: float | None = None) -> dict[str, np.ndarray]:
    """The default scene at ``speed`` (m/s) through the measurement chain: ``{"time": …, probe: a (m/s²)}``."""
    data = default_scene_data()
    data.update(models=["fem"], estimators=[], time={"end": 0.6})
    data["cars"][0]["velocity"] = speed
    if gear_damping is not None:
        data["couplers"][0]["law"]["draft_gear"]["gear_damping"] = gear_damping
    fem = run_scene(scene_from_case(parse_case(data, source="<make_records>"))).results[0]
    return fem.measured


def main() -> None:
    rng = np.random.default_rng(2026)
    pieces = [impact(2.2), impact(4.0, gear_damping=1.0e5)]
    rate = 1.0 / float(pieces[0]["time"][1] - pieces[0]["time"][0])
    quiet = int(QUIET * rate)
    probes = [p for p in pieces[0] if p != "time"]
    stream = {p: [] for p in probes}
    for piece in pieces:
        for p in probes:
            stream[p] += [rng.normal(0.0, 0.05, quiet), piece[p]]
    for p in probes:
        stream[p] = np.concatenate(stream[p] + [rng.normal(0.0, 0.05, quiet)])
    t = np.arange(stream[probes[0]].size) / rate
    hammer = {"time_s": t, **{p.split("/")[1]: stream[p] / 9.80665 + 0.02 / 9.80665 for p in probes if p.startswith("hammer/")}}
    anvil = {"time_ms": (t + ANVIL_CLOCK) * 1e3, **{p.split("/")[1]: stream[p] * 1e3 for p in probes if p.startswith("anvil/")}}
    for name, columns in (("hammer", hammer), ("anvil", anvil)):
        np.savetxt(HERE / f"{name}.csv", np.column_stack(list(columns.values())), delimiter=",", header=",".join(columns), comments="", fmt="%.7g")


if __name__ == "__main__":
    main()
