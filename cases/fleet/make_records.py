"""Write the records of ``cases/fleet/yard.yaml``: the two impacts of ``cases/measured_yard.yaml``, one recording each.

The gallery's measured stream (``cases/data/measured``: two recorders, two impacts 1.5 s apart) cut into one pair of
files per impact, as a logger that writes a file per event would: from 0.6 s before the impact to 1.3 s after it
began, each recorder's columns and units as they are (the hammer's in g with its time in s, the anvil's in mm/s² with
its time in ms on its own clock). ``python cases/fleet/make_records.py`` rewrites the four files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
SOURCE = HERE.parent / "data" / "measured"
#: Where each impact begins in the gallery's stream (s): 1.5 s of noise, then the impact's 0.6 s, then 1.5 s again.
IMPACTS = {"impact_1": 1.5, "impact_2": 3.6}
BEFORE, AFTER = 0.6, 1.3  # s kept around an impact's start


def main() -> None:
    for recorder, time_column, scale in (("hammer", "time_s", 1.0), ("anvil", "time_ms", 1e-3)):
        path = SOURCE / f"{recorder}.csv"
        header = path.read_text().splitlines()[0]
        table = np.loadtxt(path, delimiter=",", skiprows=1)
        t = table[:, header.split(",").index(time_column)] * scale
        for name, start in IMPACTS.items():
            kept = table[(t >= start - BEFORE) & (t < start + AFTER)]
            (HERE / name).mkdir(exist_ok=True)
            np.savetxt(HERE / name / f"{recorder}.csv", kept, delimiter=",", header=header, comments="", fmt="%.7g")


if __name__ == "__main__":
    main()
