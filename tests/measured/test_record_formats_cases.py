"""The same recording in every record format gives a measured case the same events as today's CSV (peaks to 1e-12);
a format whose package is missing, or a CSV option on a file that is not CSV, is refused at validation (exit 2)."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from femref.case import load_case
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case

from measured.test_hostile_records import G, RATE, SECONDS, assert_refused, pulse, run, write_case

T = np.arange(0.0, SECONDS, 1.0 / RATE)
FRONT = np.round(pulse(T) / G, 9)  # g, 10 digits: UFF58's ASCII (12) holds them exactly
REAR = -0.8 * FRONT
G_UNITS = {"a/front": {"unit": "g"}, "b/rear": {"unit": "g"}}


def csv_file(folder: Path) -> tuple[Path, dict, dict, dict]:
    path = folder / "r.csv"
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["t", "front", "rear"])
        writer.writerows([repr(float(v)) for v in row] for row in zip(T, FRONT, REAR))
    return path, {"column": "t", "unit": "s"}, {"a/front": {"column": "front", "unit": "g"}, "b/rear": {"column": "rear", "unit": "g"}}, {}


def excel_csv_file(folder: Path) -> tuple[Path, dict, dict, dict]:
    """A German Excel export: a byte-order mark, ``;``, decimal commas, every cell quoted."""
    path = folder / "r_excel.csv"
    with path.open("w", newline="", encoding="utf-8-sig") as handle:
        writer = csv.writer(handle, delimiter=";", quoting=csv.QUOTE_ALL)
        writer.writerow(["t", "front", "rear"])
        writer.writerows([repr(float(v)).replace(".", ",") for v in row] for row in zip(T, FRONT, REAR))
    return path, {"column": "t", "unit": "s"}, {"a/front": {"column": "front", "unit": "g"}, "b/rear": {"column": "rear", "unit": "g"}}, {"decimal": ","}


def hdf5_file(folder: Path) -> tuple[Path, dict, dict, dict]:
    path = folder / "r.h5"
    with h5py.File(path, "w") as h5:
        h5["t"], h5["front"], h5["rear"] = T, FRONT, REAR
    return path, {"dataset": "t", "unit": "s"}, {"a/front": {"dataset": "front", "unit": "g"}, "b/rear": {"dataset": "rear", "unit": "g"}}, {}


def mdf4_file(folder: Path) -> tuple[Path, dict, dict, dict]:
    asammdf = pytest.importorskip("asammdf")
    path = folder / "r.mf4"
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(FRONT, T, name="front", unit="g"), asammdf.Signal(REAR, T, name="rear", unit="g")])
    mdf.save(path, overwrite=True)
    return path, {"channel": "time"}, {"a/front": {"channel": "front"}, "b/rear": {"channel": "rear"}}, {}


def tdms_file(folder: Path) -> tuple[Path, dict, dict, dict]:
    nptdms = pytest.importorskip("nptdms")
    path = folder / "r.tdms"
    with nptdms.TdmsWriter(path) as writer:
        writer.write_segment([nptdms.ChannelObject("rec", name, values, {"unit_string": unit})
                              for name, values, unit in (("t", T, "s"), ("front", FRONT, "g"), ("rear", REAR, "g"))])
    return path, {"channel": "rec/t"}, {"a/front": {"channel": "rec/front"}, "b/rear": {"channel": "rec/rear", "unit": "g"}}, {}


def uff58_file(folder: Path) -> tuple[Path, dict, dict, dict]:
    pyuff = pytest.importorskip("pyuff")
    path = folder / "r.uff"
    axes = {f"{axis}_{key}": value for axis in ("abscissa", "ordinate", "orddenom", "z_axis")
            for key, value in (("spec_data_type", 0), ("len_unit_exp", 0), ("force_unit_exp", 0), ("temp_unit_exp", 0), ("axis_lab", "NONE"),
                               ("axis_units_lab", "NONE"))}
    sets = [axes | {"type": 58, "binary": 0, "func_type": 1, "func_id": node, "ver_num": 0, "load_case_id": 0, "id1": name, "id2": "NONE", "id3": "NONE",
                    "id4": "NONE", "id5": "NONE", "rsp_ent_name": "car", "rsp_node": node, "rsp_dir": 1, "ref_ent_name": "NONE", "ref_node": 0, "ref_dir": 0,
                    "ord_data_type": 4, "num_pts": T.size, "abscissa_spacing": 0, "abscissa_min": 0.0, "abscissa_inc": 1.0 / RATE, "z_axis_value": 0.0,
                    "n_bytes": 0, "x": T, "data": values, "abscissa_axis_units_lab": "s", "ordinate_axis_units_lab": "g"}
            for node, name, values in ((1, "front", FRONT), (2, "rear", REAR))]
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path, {"channel": "front"}, {"a/front": {"channel": "front"}, "b/rear": {"channel": "rear"}}, {}


FILES = [csv_file, excel_csv_file, hdf5_file, mdf4_file, tdms_file, uff58_file]


def peaks(folder: Path, make) -> list[tuple[float, ...]]:
    path, time, channels, options = make(folder)
    case = write_case(folder, path, time=time, channels=channels)
    data = yaml.safe_load(case.read_text())
    data["records"][0].update(options)
    case.write_text(yaml.safe_dump(data, sort_keys=False))
    events = run_measured(scene_from_case(load_case(case))).events
    return [tuple(estimate.peak[0] for estimate in event.estimates) + (event.trigger_time,) for event in events]


@pytest.mark.parametrize("make", FILES[1:], ids=lambda make: make.__name__)
def test_every_format_gives_the_csv_events(tmp_path, make):
    (tmp_path / "csv").mkdir()
    (tmp_path / "other").mkdir()
    truth = peaks(tmp_path / "csv", csv_file)
    assert len(truth) == 1
    np.testing.assert_allclose(peaks(tmp_path / "other", make), truth, rtol=1e-12, atol=0)


@pytest.mark.parametrize("make, package", [(mdf4_file, "asammdf"), (tdms_file, "nptdms"), (uff58_file, "pyuff")], ids=["mdf4", "tdms", "uff58"])
def test_a_missing_package_exits_2_naming_the_extra(tmp_path, monkeypatch, make, package):
    path, time, channels, _ = make(tmp_path)
    case = write_case(tmp_path, path, time=time, channels=channels)
    monkeypatch.setitem(sys.modules, package, None)
    output = tmp_path / "out.h5"
    assert_refused(run(case, output), case, output, r"records\[0\]", rf"{path.name}: reading .* files needs the package {package}: "
                                                                          r"pip install 'femref\[formats\]'")


def test_a_csv_option_on_a_file_that_is_not_csv_is_refused(tmp_path):
    path, time, channels, _ = hdf5_file(tmp_path)
    case = write_case(tmp_path, path, time=time, channels=channels)
    data = yaml.safe_load(case.read_text())
    data["records"][0]["decimal"] = ","
    case.write_text(yaml.safe_dump(data, sort_keys=False))
    output = tmp_path / "out.h5"
    assert_refused(run(case, output), case, output, r"records\[0\]\.decimal", "is a CSV option; r.h5 is read as HDF5")
