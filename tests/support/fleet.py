"""A small fleet for the fleet tests: fem impacts recorded through the measurement chain (tests/support/measured.py)
at a gentle and a hard speed, copied into one folder per recording, and manifests over them.

:func:`simulate_records` simulates the two impacts (tests/fleet/conftest.py: once per session). ``write_fleet(folder, plan)`` writes a manifest
whose recording ``i`` is ``plan[i] = (days ago, "low" | "high", rear car, front car)``: the low impact (2 m/s, the
default scene: peak about 1.7 MN, the gear open) or the high one (4 m/s, the gear driven solid: peak above the
alarm limit :data:`ALARM`), its files copied into the recording's own folder.
"""

from __future__ import annotations

import copy
import shutil
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import yaml

from femref.case.defaults import default_scene_data
from support.measured import simulated_event

#: The fleet's alarm limit (N): between the low impact's peak and the high one's.
ALARM = 2.5e6
#: The gears' rated closure force (N) and the wear tolerance.
RATED, WEAR_TOLERANCE = 2.9e6, 0.15
#: Estimators of every recording: the cheap inverse ones (the kalman's cost is not what these tests are about).
ESTIMATORS = ["inverse_rigid", "inverse_quasi_rigid"]
HAMMER_SENSORS, ANVIL_SENSORS = {"center": 0.0, "front": 8.3}, {"rear": -8.3, "center": 0.0, "front": 8.3}


def _impact(speed: float, gear_damping: float | None) -> dict[str, Any]:
    data = default_scene_data()
    data["cars"][0]["velocity"] = speed
    data["time"] = {"end": 0.4}
    if gear_damping is not None:
        data["couplers"][0]["law"]["draft_gear"].update(gear_damping=gear_damping)
    return data


def simulate_records(folder: Path) -> dict[str, Path]:
    """``"low"``/``"high"`` → the folder (in ``folder``) of that impact's recorders' files (hammer.csv, anvil.csv; time
    column t, in g)."""
    folders = {}
    for kind, speed, damping in (("low", 2.0, None), ("high", 4.0, 1.0e5)):
        folders[kind] = folder / f"impact_{kind}"
        folders[kind].mkdir(parents=True, exist_ok=True)
        simulated_event(folders[kind], _impact(speed, damping), estimators=tuple(ESTIMATORS))
    return folders


def car_entries(count: int) -> dict[str, dict[str, Any]]:
    """``C0001``…: odd cars the default scene's hammer (119 t), even cars its anvil (100 t), with their sensors."""
    hammer, anvil = default_scene_data()["cars"]
    return {f"C{k:04d}": {"body": (hammer if k % 2 else anvil)["body"], "sensors": dict(HAMMER_SENSORS if k % 2 else ANVIL_SENSORS)}
            for k in range(1, count + 1)}


def recording_name(index: int, start: datetime, rear: str, front: str) -> str:
    return f"{start:%Y-%m-%dT%H-%M}_{index:03d}_{rear}_{front}"


def write_fleet(folder: Path, records: dict[str, Path], plan: list[tuple[float, str, str, str]], now: datetime | None = None,
                name: str = "west-yard") -> Path:
    """The manifest ``folder/fleet.yaml`` of ``plan`` (module docstring); its path."""
    now = now or datetime.now(timezone.utc)
    folder.mkdir(parents=True, exist_ok=True)
    recordings = []
    for i, (days_ago, kind, rear, front) in enumerate(plan):
        start = (now - timedelta(days=days_ago)).replace(microsecond=0)
        rec = recording_name(i, start, rear, front)
        (folder / rec).mkdir(exist_ok=True)
        for file in ("hammer.csv", "anvil.csv"):
            shutil.copy(records[kind] / file, folder / rec / file)
        recordings.append({
            "name": rec, "start": start.isoformat().replace("+00:00", "Z"), "track": f"yard {i % 3 + 1}", "cars": [rear, front],
            "couplers": [{"name": "c1", "gear": "G0001" if i % 2 else "G0002"}],
            "records": [
                {"file": f"{rec}/hammer.csv", "time": {"column": "t", "unit": "s"}, "anti_alias": {"corner": 100.0, "order": 4},
                 "channels": {f"{rear}/{s}": {"column": s, "unit": "g"} for s in HAMMER_SENSORS}},
                {"file": f"{rec}/anvil.csv", "time": {"column": "t", "unit": "s"}, "anti_alias": {"corner": 100.0, "order": 4},
                 "channels": {f"{front}/{s}": {"column": s, "unit": "g"} for s in ANVIL_SENSORS}},
            ],
        })
    cars = sorted({car for _, _, rear, front in plan for car in (rear, front)})
    law = default_scene_data()["couplers"][0]["law"]
    manifest = {
        "fleet": name,
        "defaults": {"events": {"trigger": 3.0, "pre": 0.05, "post": 0.39}, "estimators": list(ESTIMATORS),
                     "checks": {"alarm": ALARM, "rated_closure_force": 2.0e6, "wear_tolerance": WEAR_TOLERANCE}},
        "cars": {car: entry for car, entry in car_entries(max(int(c[1:]) for c in cars)).items() if car in cars},
        "gears": {"G0001": {"law": law, "rated_closure_force": RATED}, "G0002": {"law": copy.deepcopy(law)}},
        "recordings": recordings,
    }
    path = folder / "fleet.yaml"
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))
    return path


#: Hammer-type cars are odd, anvil-type even: (rear, front) pairs that match the records.
PAIRS = [("C0001", "C0002"), ("C0003", "C0004"), ("C0005", "C0006")]
