"""Headline scalars of a result file, and the baselines the example cases are held to.

Every case in ``cases/`` has one or two headline scalars (``tests/examples/baselines.json``):

* impact cases: the fem run's peak coupler force (worst coupler, N) and its energy
  balance error (the result file's ``settings.energy_balance_error``);
* measured cases: every event's peak force of every estimator and coupler (N);
* single-body cases: the reference model's peak acceleration magnitude over all probes
  (m/s²; ``exact`` where the case runs it, else ``fem``), and for transient fem runs the
  energy balance error.

Each baseline carries its own tolerance: ``rtol`` (relative) for physical outputs, or
``at_most`` for a balance error (round-off and contact-change bookkeeping, which may
move within its bound but must not grow past it).

To regenerate after a deliberate change (say what moved and why in the commit)::

    .venv/bin/python tests/support/headlines.py            # runs every case, rewrites the file

Tolerances already in the file are kept; new keys get the defaults below.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np
import yaml

BASELINES = Path(__file__).resolve().parents[1] / "examples" / "baselines.json"
PEAK_RTOL = 1e-6
"""Relative tolerance of a peak force or acceleration: far above round-off across machines, far below any modelling change."""
BALANCE_FACTOR = 10.0
"""A balance error may grow to this multiple of its baseline (at least ``BALANCE_FLOOR``)."""
BALANCE_FLOOR = 1e-9


def headlines(path: str | Path) -> dict[str, float]:
    """The headline scalars of the result file at ``path`` (module docstring)."""
    with h5py.File(path, "r") as h5:
        kind = yaml.safe_load(h5.attrs["case_yaml"])["kind"]
        out: dict[str, float] = {}
        if kind == "measured":
            for k, event in h5["events"].items():
                for estimator, group in event.items():
                    if estimator in ("records", "closure"):
                        continue
                    for coupler, estimate in group.items():
                        out[f"events.{k}.{estimator}.{coupler}.peak_force"] = float(estimate.attrs["peak_force"])
            return out
        if kind == "impact":
            fem = h5["fem"]
            out["fem.peak_coupler_force"] = max(float(np.max(g["force"][()])) for g in fem["couplers"].values())
            out["fem.energy_balance_error"] = float(json.loads(fem.attrs["settings"])["energy_balance_error"])
            return out
        reference = "exact" if "exact" in h5 else "fem"
        probes = h5[reference]["probes"]
        out[f"{reference}.peak_acceleration"] = max(float(np.max(np.abs(p["acceleration"][()]))) for p in probes.values())
        settings = json.loads(h5["fem"].attrs["settings"])
        if "energy_balance_error" in settings:
            out["fem.energy_balance_error"] = float(settings["energy_balance_error"])
        return out


def check(case: str, values: dict[str, float], baselines: dict) -> list[str]:
    """The ways ``values`` of ``case`` break its baselines (empty when they hold)."""
    expected = baselines["cases"].get(case)
    if expected is None:
        return [f"{case}: no baseline (regenerate: python tests/support/headlines.py)"]
    problems = [f"{case}: {key} has no value in the result" for key in expected if key not in values]
    for key, rule in expected.items():
        if key not in values:
            continue
        value = values[key]
        if "at_most" in rule and not value <= rule["at_most"]:
            problems.append(f"{case}: {key} = {value:.6g} exceeds its bound {rule['at_most']:.3g}")
        if "rtol" in rule and not abs(value - rule["value"]) <= rule["rtol"] * abs(rule["value"]):
            problems.append(f"{case}: {key} = {value!r}, baseline {rule['value']!r} (rtol {rule['rtol']:g})")
    return problems


def _rule(key: str, value: float, old: dict | None) -> dict:
    if key.endswith("energy_balance_error"):
        bound = old["at_most"] if old and "at_most" in old else max(BALANCE_FACTOR * value, BALANCE_FLOOR)
        return {"value": value, "at_most": bound}
    return {"value": value, "rtol": old["rtol"] if old and "rtol" in old else PEAK_RTOL}


def regenerate(repo: Path) -> dict:
    """Run every case through ``femref run`` and return the new baselines (tolerances kept)."""
    old = json.loads(BASELINES.read_text())["cases"] if BASELINES.exists() else {}
    cases = {}
    with tempfile.TemporaryDirectory() as tmp:
        for case in sorted((repo / "cases").glob("*.yaml")):
            output = Path(tmp) / f"{case.stem}.h5"
            subprocess.run([str(Path(sys.executable).with_name("femref")), "run", str(case), "-o", str(output)], check=True, capture_output=True)
            values = headlines(output)
            cases[case.stem] = {key: _rule(key, value, old.get(case.stem, {}).get(key)) for key, value in values.items()}
    note = "Headline scalars of every case in cases/ (tests/support/headlines.py); regenerate with: python tests/support/headlines.py"
    return {"note": note, "cases": cases}


if __name__ == "__main__":
    BASELINES.write_text(json.dumps(regenerate(BASELINES.parents[2]), indent=2) + "\n")
    print(f"wrote {BASELINES}")
