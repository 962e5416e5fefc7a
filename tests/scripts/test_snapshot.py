"""scripts/snapshot.py, the "no number moves" instrument of issue 29: ``compare`` finds exactly the numbers
that moved beyond the tolerance, and nothing in two copies of the same snapshot.

One case (cases/rod_harmonic.yaml) is run once through ``take`` (the command line's code path) and the
folder copied; the copy is then perturbed by hand: a dataset by 1e-6 of its max |value|, a scalar attribute
by 1e-6 of itself, a second dataset by 1e-12 (inside the default rtol 1e-10), the run-dependent wall time
and creation time (excluded), and a gallery headline by 1e-6 and another by 1e-12.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys

import h5py
import numpy as np
import pytest

from support.paths import REPO


@pytest.fixture(scope="module")
def snapshot():
    """``scripts/snapshot.py`` imported as module ``snapshot_script`` (registered so that its dataclass resolves)."""
    spec = importlib.util.spec_from_file_location("snapshot_script", REPO / "scripts" / "snapshot.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    yield module
    del sys.modules[spec.name]


@pytest.fixture(scope="module")
def taken(snapshot, tmp_path_factory):
    """A snapshot of rod_harmonic (no gallery) plus a hand-written gallery.json, taken once."""
    folder = tmp_path_factory.mktemp("snapshot") / "a"
    assert snapshot.take(folder, only=["rod_harmonic"], gallery=False) == 0
    headlines = {"rigid_impacts": {"peak_force_MN": 1.75, "solid_speeds": 2}, "two_value_rod": {"order": 3.98}}
    (folder / snapshot.GALLERY_FILE).write_text(json.dumps(headlines), encoding="utf-8")
    return folder


def copy_of(folder, tmp_path):
    shutil.copytree(folder, tmp_path / "b")
    return tmp_path / "b"


def test_identical_copies_compare_clean_and_exit_0(snapshot, taken, tmp_path, capsys):
    """A copy of a snapshot: 0 differences, exit 0, and the summary counts what was walked."""
    copy = copy_of(taken, tmp_path)
    report = snapshot.compare(taken, copy)
    assert report.differences == []
    assert report.files == 2 and report.datasets > 50 and report.attributes > 50 and report.headlines == 3
    assert snapshot.main(["compare", str(taken), str(copy)]) == 0
    assert "0 difference(s)" in capsys.readouterr().out


def test_compare_finds_exactly_the_moved_numbers(snapshot, taken, tmp_path, capsys):
    """Moved beyond 1e-10: /fem/probes/center/acceleration (1e-6 of its max |value|), /scene@epsilon (1e-6 of
    itself), one gallery headline (1e-6). Not reported: a dataset moved by 1e-12, a headline moved by 1e-12, the
    wall times and the creation time (run-dependent, excluded). At rtol 1e-5 nothing differs."""
    copy = copy_of(taken, tmp_path)
    with h5py.File(copy / "rod_harmonic.h5", "r+") as h5:
        moved = h5["fem/probes/center/acceleration"]
        moved[...] = moved[()] * (1.0 + 1e-6)
        inside = h5["exact/probes/left/displacement"]
        inside[...] = inside[()] * (1.0 + 1e-12)
        h5["scene"].attrs["epsilon"] = h5["scene"].attrs["epsilon"] * (1.0 + 1e-6)
        h5["fem"].attrs["wall_time_s"] = 123.0
        h5.attrs["created"] = "1999-01-01T00:00:00+00:00"
    headlines = json.loads((copy / snapshot.GALLERY_FILE).read_text(encoding="utf-8"))
    headlines["rigid_impacts"]["peak_force_MN"] *= 1.0 + 1e-6
    headlines["two_value_rod"]["order"] *= 1.0 + 1e-12
    (copy / snapshot.GALLERY_FILE).write_text(json.dumps(headlines), encoding="utf-8")

    report = snapshot.compare(taken, copy)
    where = sorted(place for place, _ in report.differences)
    assert where == ["gallery.json:rigid_impacts.peak_force_MN", "rod_harmonic.h5:/fem/probes/center/acceleration",
                     "rod_harmonic.h5:/scene@epsilon"]
    size = dict(report.differences)["rod_harmonic.h5:/fem/probes/center/acceleration"]
    assert "= 1.000e-06 of max |value|" in size
    assert snapshot.main(["compare", str(taken), str(copy)]) == 1
    assert "3 difference(s)" in capsys.readouterr().out
    assert snapshot.compare(taken, copy, rtol=1e-5).differences == []


def test_strings_json_and_missing_items_are_compared_exactly(snapshot, taken, tmp_path):
    """A changed status string, a changed JSON settings value, a dataset removed (a model's plain axis copy) and a field-file digest changed
    (excluded: the field files are compared themselves) give exactly three differences."""
    copy = copy_of(taken, tmp_path)
    with h5py.File(copy / "rod_harmonic.h5", "r+") as h5:
        h5["rigid"].attrs["status"] = "failed"
        settings = json.loads(h5["fem"].attrs["settings"])
        settings["element"] = "P1"
        h5["fem"].attrs["settings"] = json.dumps(settings)
        del h5["quasi_rigid/lambda"]
        h5["fem"].attrs["field_files"] = json.dumps({"x_fields.h5": "0" * 64})
    with h5py.File(taken / "rod_harmonic.h5", "r+") as h5:
        h5["fem"].attrs["field_files"] = json.dumps({"x_fields.h5": "f" * 64})
    try:
        where = sorted(place for place, _ in snapshot.compare(taken, copy).differences)
    finally:
        with h5py.File(taken / "rod_harmonic.h5", "r+") as h5:
            del h5["fem"].attrs["field_files"]
    assert where == ["rod_harmonic.h5:/fem@settings.element", "rod_harmonic.h5:/quasi_rigid/lambda",
                     "rod_harmonic.h5:/rigid@status"]


def test_nan_places_and_all_zero_arrays_must_match(snapshot):
    """NaN where the other has a number is a difference whatever rtol; an all-zero array must stay exactly zero."""
    assert snapshot._numeric_difference(np.array([1.0, np.nan]), np.array([1.0, np.nan]), 1e-10) is None
    assert "NaN" in snapshot._numeric_difference(np.array([1.0, np.nan]), np.array([1.0, 2.0]), 1.0)
    assert snapshot._numeric_difference(np.zeros(3), np.array([0.0, 1e-300, 0.0]), 1e-10)


def test_dimension_scale_references_compare_by_the_name_they_point_to(snapshot, taken):
    """``DIMENSION_LIST`` of a probe's history names its model's frequency axis (the scale hard-linked into each
    probe group, named by its first path); ``REFERENCE_LIST`` of that scale names every history attached to it."""
    with h5py.File(taken / "rod_harmonic.h5", "r") as h5:
        resolve = snapshot._resolver(h5)
        assert snapshot._dereference(h5["fem/probes/left/acceleration"].attrs["DIMENSION_LIST"], resolve) == [["/fem/probes/center/omega"]]
        attached = snapshot._dereference(h5["fem/probes/center/omega"].attrs["REFERENCE_LIST"], resolve)
        assert ["/fem/probes/right/displacement", 0] in attached and all(name.startswith("/fem/probes/") for name, _ in attached)


def test_paths_inside_each_checkout_compare_equal(snapshot, taken, tmp_path):
    """A snapshot of another checkout (root /elsewhere/femref in its snapshot.json) whose strings name the same
    file under its own root: no difference; a path that differs below the root still does."""
    copy = copy_of(taken, tmp_path)
    facts = json.loads((copy / snapshot.SNAPSHOT_FILE).read_text(encoding="utf-8"))
    root, facts["repo"] = facts["repo"], "/elsewhere/femref"
    (copy / snapshot.SNAPSHOT_FILE).write_text(json.dumps(facts), encoding="utf-8")
    with h5py.File(copy / "rod_harmonic.h5", "r+") as h5:
        h5.attrs["case_yaml"] = h5.attrs["case_yaml"] + "records: [/elsewhere/femref/cases/data/a.csv]\n"
        h5["fem"].attrs["settings"] = json.dumps({"network": "/elsewhere/femref/cases/networks/b.npz"})
    with h5py.File(taken / "rod_harmonic.h5", "r+") as h5:
        saved = h5.attrs["case_yaml"], h5["fem"].attrs["settings"]
        h5.attrs["case_yaml"] = saved[0] + f"records: [{root}/cases/data/a.csv]\n"
        h5["fem"].attrs["settings"] = json.dumps({"network": f"{root}/cases/networks/c.npz"})
    try:
        differences = snapshot.compare(taken, copy).differences
    finally:
        with h5py.File(taken / "rod_harmonic.h5", "r+") as h5:
            h5.attrs["case_yaml"], h5["fem"].attrs["settings"] = saved
    assert [where for where, _ in differences] == ["rod_harmonic.h5:/fem@settings.network"]
    assert "<repo>/cases/networks/c.npz" in differences[0][1]
