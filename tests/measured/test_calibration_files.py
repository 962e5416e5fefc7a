"""Hostile and broken calibration files (issue 33): refused at validation, before anything large is read.

Every probe writes a valid calibration of the yard's two cars and coupler with
:func:`femref.sensing.calibration.write_calibration` and then breaks it the way a hostile or damaged
file would — a string where a mass range belongs, JSON nested 200 000 deep, a dataset that declares
16 GiB in a few kB of compressed chunks, infinite or reversed ranges, a calibration of another
coupler, raw data stored in another file, an external or soft link, a virtual dataset, a filter
femref does not decode, a FIFO. ``femref validate`` (and ``femref run``) on the yard case naming it
must exit 2 with ``<case>: calibration: <file>: <attribute or dataset>: <rule>`` and write nothing.
Before issue 33 the string, the bomb and the deep JSON passed validation and crashed the run (the
bomb at 18 GB of memory), and the links, external storage, virtual dataset and unknown filter were
read as if they were data.

Also here: the tolerance of the mass-range compare (a zero-width range of a sweep that held the mass
fixed meets the case's own mass), the soft coupler's time step (a measurement low-pass on a rigid
run), and the report pages showing no local path.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.cli import main
from femref.sensing.calibration import RANGE_RTOL, Calibration, read_calibration, within, write_calibration
from femref.sensing.hdf5_checks import HDF5ObjectError, check_regular_file
from support.measured import yard_case_with_inverse_estimators
from support.paths import CASES

#: The yard's car masses (kg) from their profiles by hand: 2 m end structures of 3500 kg/m at each end and
#: 13 m of lading at 8076.923 (hammer) or 6615.385 kg/m (anvil) — the integral of the piecewise constant.
HAMMER = 3500.0 * 4.0 + 8076.923 * 13.0
ANVIL = 3500.0 * 4.0 + 6615.385 * 13.0
ERRORS = np.linspace(0.05, 0.09, 40)  # inputs that make a band (relative peak errors), not results under test


def calibration(**changes: Any) -> Calibration:
    """A calibration of the yard's coupler c1, wide around its cars, speeds, chain and noise: every event is inside."""
    fields: dict[str, Any] = dict(coupler="c1", errors={"inverse_rigid": ERRORS, "inverse_quasi_rigid": ERRORS}, closing_speed=(0.5, 6.0),
                                  masses={"hammer": (1.0e5, 1.4e5), "anvil": (8.0e4, 1.2e5)}, lowpass=100.0, noise=(0.0, 0.5))
    fields.update(changes)
    return Calibration(**fields)


def attribute(name: str, value: Any) -> Callable[[Path], None]:
    """A writer: the valid file with root attribute ``name`` replaced by ``value``."""

    def write(path: Path) -> None:
        write_calibration(calibration(), path)
        with h5py.File(path, "a") as h5:
            h5.attrs[name] = value

    return write


def edited(change: Callable[[h5py.File, Path], None]) -> Callable[[Path], None]:
    """A writer: the valid file changed in place by ``change(h5, folder)``."""

    def write(path: Path) -> None:
        write_calibration(calibration(), path)
        with h5py.File(path, "a") as h5:
            change(h5, path.parent)

    return write


def _replace(h5: h5py.File, make: Callable[[], Any]) -> None:
    del h5["errors/inverse_rigid"]
    h5["errors/inverse_rigid"] = make()


def _bomb(h5: h5py.File, folder: Path) -> None:
    """16 GiB declared (2³¹ doubles), one 8 MiB chunk of zeros written: a file of about 40 kB."""
    del h5["errors/inverse_rigid"]
    h5.create_dataset("errors/inverse_rigid", shape=(2**31,), dtype="f8", chunks=(2**20,), compression="gzip", fillvalue=0.0)
    h5["errors/inverse_rigid"][: 2**20] = 0.0


def _external_storage(h5: h5py.File, folder: Path) -> None:
    (folder / "outside.bin").write_bytes(np.zeros(40).tobytes())
    del h5["errors/inverse_rigid"]
    h5.create_dataset("errors/inverse_rigid", shape=(40,), dtype="f8", external=[(str(folder / "outside.bin"), 0, 320)])


def _external_link(h5: h5py.File, folder: Path) -> None:
    with h5py.File(folder / "other.h5", "w") as other:
        other["errors/inverse_rigid"] = ERRORS
    del h5["errors"]
    h5["errors"] = h5py.ExternalLink(str(folder / "other.h5"), "errors")


def _virtual(h5: h5py.File, folder: Path) -> None:
    layout = h5py.VirtualLayout(shape=(40,), dtype="f8")
    layout[:] = h5py.VirtualSource(str(folder / "missing.h5"), "errors", shape=(40,))
    del h5["errors/inverse_rigid"]
    h5.create_virtual_dataset("errors/inverse_rigid", layout, fillvalue=0.0)


def _blosc(h5: h5py.File, folder: Path) -> None:
    """A chunked dataset declaring filter 32001 (Blosc), optional so HDF5 lets it be made without the plugin."""
    del h5["errors/inverse_rigid"]
    plist = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    plist.set_chunk((40,))
    plist.set_filter(32001, h5py.h5z.FLAG_OPTIONAL, (0, 0, 0, 0, 5, 1, 1))
    h5py.h5d.create(h5["errors"].id, b"inverse_rigid", h5py.h5t.IEEE_F64LE, h5py.h5s.create_simple((40,)), dcpl=plist)


def _fifo(path: Path) -> None:
    os.mkfifo(path)


def _with_nan() -> np.ndarray:
    errors = ERRORS.copy()
    errors[3] = np.nan
    return errors


#: id → (writer, rule after "<case>: calibration: <file>: " (a regex)); the fast ones run through femref validate.
HOSTILE: dict[str, tuple[Callable[[Path], None], str]] = {
    "string in masses": (attribute("masses", json.dumps({"hammer": ["a", "b"], "anvil": [8e4, 1.2e5]})),
                         r"attribute masses, car hammer must be \[lo, hi\] \(kg\): two finite numbers, lo > 0, lo <= hi; got \[\"a\", \"b\"\]"),
    "a car's range a string": (attribute("masses", json.dumps({"hammer": "heavy", "anvil": [8e4, 1.2e5]})),
                               r"attribute masses, car hammer must be \[lo, hi\] \(kg\).*; got \"heavy\""),
    "masses not a mapping": (attribute("masses", "[1, 2]"), r"attribute masses must be a JSON mapping \{car: \[lo, hi\]\} \(kg\) of at least one car, got \[1, 2\]"),
    "JSON 200 000 deep": (attribute("masses", "[" * 200_000 + "]" * 200_000), "attribute masses is JSON nested too deeply to read"),
    "JSON that does not parse": (attribute("noise", "[0, 0.5"), "attribute noise is not JSON text: "),
    "infinite speeds": (attribute("closing_speed", "[-Infinity, Infinity]"),
                        r"attribute closing_speed must be \[lo, hi\] \(m/s\): two finite numbers, lo >= 0, lo <= hi; got \[-Infinity, Infinity\]"),
    "infinite masses": (attribute("masses", json.dumps({"hammer": [-math.inf, math.inf], "anvil": [8e4, 1.2e5]})),
                        r"attribute masses, car hammer must be .*; got \[-Infinity, Infinity\]"),
    "NaN noise": (attribute("noise", "[0, NaN]"), r"attribute noise must be \[lo, hi\] \(m/s²\).*; got \[0, NaN\]"),
    "reversed speeds": (attribute("closing_speed", "[6.0, 0.5]"), r"attribute closing_speed must be .*lo <= hi; got \[6.0, 0.5\]"),
    "negative noise": (attribute("noise", "[-1, 0.5]"), r"attribute noise must be .*lo >= 0.*; got \[-1, 0.5\]"),
    "lowpass a string": (attribute("lowpass", '"fast"'), r"attribute lowpass must be null or a finite corner frequency > 0 \(Hz\), got \"fast\""),
    "unknown impact type": (attribute("impact_type", "sideways"), "attribute impact_type is 'sideways'; it must be one of free_to_roll, coupled"),
    "coupler an array": (attribute("coupler", np.arange(3)), r"attribute coupler has shape \(3,\); it must be a single text"),
    "coupler a number": (attribute("coupler", 7), r"attribute coupler holds int64 values; it must be text"),
    "another coupler": (attribute("coupler", "c9"),
                        "attribute coupler: the calibration is of coupler 'c9', which this case does not have; couplers: c1"),
    "other cars": (attribute("masses", json.dumps({"hammer": [1e5, 1.4e5], "tanker": [8e4, 1.2e5]})),
                   "attribute masses calibrates cars hammer, tanker, not this case's hammer, anvil"),
    "unknown attribute": (attribute("smuggled", "x"), r"not a femref calibration file: it has unknown attribute\(s\) smuggled"),
    "a member beside /errors": (edited(lambda h5, folder: h5.create_dataset("payload", data=np.zeros(3))),
                                r"unknown member\(s\) /payload; a calibration file holds only /errors"),
    "bomb dataset (16 GiB declared)": (edited(_bomb), r"/errors/inverse_rigid declares shape \(2147483648,\), 2147483648 values, "
                                                      r"more than the 16777216 it may hold \(refused unread\)"),
    "errors of text": (edited(lambda h5, folder: _replace(h5, lambda: np.array([b"x"] * 40))),
                       r"/errors/inverse_rigid holds values of type \|S1 \(dtype kind 'S'\); expected floating-point or integer"),
    "errors 2-D": (edited(lambda h5, folder: _replace(h5, lambda: np.zeros((40, 2)))),
                   r"/errors/inverse_rigid has shape \(40, 2\); an estimator's errors are 1-D \(samples,\)"),
    "a NaN error": (edited(lambda h5, folder: _replace(h5, _with_nan)), r"/errors/inverse_rigid holds 1 non-finite value\(s\) \(NaN or infinity\)"),
    "too few errors": (edited(lambda h5, folder: _replace(h5, lambda: ERRORS[:19])),
                       "/errors/inverse_rigid holds 19 errors, fewer than the 20 a 95 % band needs"),
    "raw data in another file": (edited(_external_storage), r"/errors/inverse_rigid keeps its raw data in external file\(s\) \S+outside\.bin: "
                                                            r"only data stored in this file are read \(refused unread\)"),
    "external link": (edited(_external_link), r"/errors is an external link to errors in the file \S+other\.h5: "
                                               r"only objects stored in this file are read \(refused unfollowed\)"),
    "soft link loop": (edited(lambda h5, folder: _replace(h5, lambda: h5py.SoftLink("/errors/inverse_rigid"))),
                       r"/errors/inverse_rigid is a soft link to /errors/inverse_rigid: only hard links are read \(refused unfollowed\)"),
    "virtual dataset": (edited(_virtual), r"/errors/inverse_rigid is a virtual dataset \(its data live in other files; "
                                          r"a missing one reads as the fill value\): only data stored in this file are read"),
    "unknown filter (Blosc)": (edited(_blosc), r"/errors/inverse_rigid is stored through chunk filter 32001 \(blosc\); femref reads only deflate"),
}
#: Path-level probes: the rule follows "<case>: calibration: calibration file <file> ".
NOT_FILES: dict[str, tuple[Callable[[Path], None], str]] = {
    "a FIFO": (_fifo, r"is not a regular file but a FIFO \(named pipe\) \(refused unopened\)"),
    "a directory": (lambda path: path.mkdir(), r"is not a regular file but a folder \(refused unopened\)"),
    "missing": (lambda path: None, "not found"),
}


@pytest.fixture(scope="module")
def yard(tmp_path_factory) -> dict[str, Any]:
    """The yard case (its shipped records, the inverse estimators) as a dict."""
    return yaml.safe_load(yard_case_with_inverse_estimators(tmp_path_factory.mktemp("yard")).read_text())


def case_naming(folder: Path, yard: dict[str, Any], calibration_file: str = "cal.h5") -> Path:
    path = folder / "case.yaml"
    path.write_text(yaml.safe_dump({**yard, "calibration": calibration_file}, sort_keys=False))
    return path


def _refused(result, case: Path, rule: str) -> None:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    text = " ".join(result.output.split())
    assert re.search(rf"{re.escape(f'{case}: calibration: ')}{rule}", text), result.output


@pytest.mark.parametrize(("writer", "rule"), list(HOSTILE.values()), ids=list(HOSTILE))
def test_hostile_calibration_file_is_refused_at_validation(yard, tmp_path: Path, writer, rule: str) -> None:
    writer(tmp_path / "cal.h5")
    case = case_naming(tmp_path, yard)
    _refused(CliRunner().invoke(main, ["validate", str(case)]), case, re.escape(f"{tmp_path / 'cal.h5'}: ") + rule)


@pytest.mark.parametrize(("writer", "rule"), list(NOT_FILES.values()), ids=list(NOT_FILES))
def test_a_calibration_that_is_not_a_regular_file_is_refused_unopened(yard, tmp_path: Path, writer, rule: str) -> None:
    writer(tmp_path / "cal.h5")
    case = case_naming(tmp_path, yard)
    _refused(CliRunner().invoke(main, ["validate", str(case)]), case, re.escape(f"calibration file {tmp_path / 'cal.h5'} ") + rule)


@pytest.mark.parametrize("probe", ["string in masses", "JSON 200 000 deep", "bomb dataset (16 GiB declared)", "another coupler"])
def test_femref_run_refuses_it_before_writing(yard, tmp_path: Path, probe: str) -> None:
    """The probes that crashed the run before (or were silently ignored): exit 2 from femref run, nothing written."""
    writer, rule = HOSTILE[probe]
    writer(tmp_path / "cal.h5")
    case = case_naming(tmp_path, yard)
    output = tmp_path / "events.h5"
    _refused(CliRunner().invoke(main, ["run", str(case), "-o", str(output)]), case, re.escape(f"{tmp_path / 'cal.h5'}: ") + rule)
    assert not output.exists() and not list(tmp_path.glob("*.h5.*")), sorted(p.name for p in tmp_path.iterdir())


def test_the_bomb_is_refused_without_reading_it(tmp_path: Path) -> None:
    """``read_calibration`` of the 16 GiB-declared dataset in a fresh process: refused with a peak resident memory
    far below the 16 GiB it declares (measured: ~0.1 GB, that of the imports; before, 18 GB and a kill). The peak is
    the process's own (``VmHWM``): ``ru_maxrss`` keeps the high-water mark of the parent's image it was forked from
    across ``exec`` (0.7 GB read under a full pytest run)."""
    HOSTILE["bomb dataset (16 GiB declared)"][0](tmp_path / "cal.h5")
    assert (tmp_path / "cal.h5").stat().st_size < 1_000_000
    script = ("import sys\nfrom femref.sensing.calibration import CalibrationFileError, read_calibration\n"
              "try:\n    read_calibration(sys.argv[1])\nexcept CalibrationFileError as error:\n    print(error)\n"
              "print(next(int(line.split()[1]) for line in open('/proc/self/status') if line.startswith('VmHWM:')))\n")
    found = subprocess.run([sys.executable, "-c", script, str(tmp_path / "cal.h5")], capture_output=True, text=True, timeout=120,
                           env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    message, peak_kib = found.stdout.strip().splitlines()
    assert "declares shape (2147483648,)" in message and "refused unread" in message, found.stderr
    assert int(peak_kib) < 500_000, f"peak RSS {int(peak_kib) / 1e6:.2f} GB"


def test_a_symlink_loop_is_named(tmp_path: Path) -> None:
    (tmp_path / "a.h5").symlink_to(tmp_path / "b.h5")
    (tmp_path / "b.h5").symlink_to(tmp_path / "a.h5")
    with pytest.raises(HDF5ObjectError, match="is a loop of symbolic links"):
        check_regular_file(tmp_path / "a.h5")


def test_a_valid_file_reads_back_as_written(tmp_path: Path) -> None:
    """The checks refuse nothing write_calibration writes: every field reads back as written."""
    written = calibration(impact_type="coupled", lowpass=None, sweep_yaml="samples: 30\n")
    read = read_calibration(write_calibration(written, tmp_path / "cal.h5"))
    assert (read.coupler, read.closing_speed, read.masses, read.lowpass, read.noise, read.impact_type, read.sweep_yaml) == (
        written.coupler, written.closing_speed, written.masses, written.lowpass, written.noise, written.impact_type, written.sweep_yaml)
    assert read.errors.keys() == written.errors.keys() and all(np.array_equal(read.errors[k], written.errors[k]) for k in written.errors)


def test_the_impact_types_are_those_the_classifier_gives() -> None:
    """The file's impact types (kept here so that reading a calibration does not import the signal tools) are
    ``reduced.signal_tools.IMPACT_KINDS``."""
    from femref.sensing.calibration import IMPACT_TYPES
    from reduced.signal_tools import IMPACT_KINDS

    assert IMPACT_TYPES == IMPACT_KINDS


# -- the range compares' tolerance ---------------------------------------------------------------


def test_a_range_edge_holds_within_the_relative_tolerance() -> None:
    """``within(v, lo, hi)``: ``lo − r|lo| <= v <= hi + r|hi|``, ``r`` = RANGE_RTOL = 1e-6. A zero-width mass range
    [m, m] takes m(1 ± r/2) and refuses m(1 ± 2r); the closing speed's interval the same at the calibrated edges."""
    m = HAMMER
    assert RANGE_RTOL == 1e-6
    assert all(within(m * (1 + s * 0.5e-6), m, m) for s in (-1, 1))
    assert not any(within(m * (1 + s * 2e-6), m, m) for s in (-1, 1))
    zero_width = calibration(masses={"hammer": (m, m), "anvil": (ANVIL, ANVIL)}, closing_speed=(2.2, 2.2))
    assert zero_width.outside((2.2 * (1 + 0.5e-6), 2.3), {"hammer": m * (1 - 0.5e-6), "anvil": ANVIL}) == []
    outside = zero_width.outside((2.2 * (1 + 2e-6), 2.3), {"hammer": m * (1 - 2e-6), "anvil": ANVIL})
    assert outside == ["closing speed [2.2, 2.3] m/s outside the calibrated [2.2, 2.2] m/s",
                       f"car hammer's mass {m * (1 - 2e-6):.6g} kg outside the calibrated [{m:.6g}, {m:.6g}] kg (relative tolerance 1e-06)"]


def test_a_zero_width_mass_range_meets_the_cases_mass(yard, tmp_path: Path) -> None:
    """A sweep that held the cars' masses fixed calibrates [m, m]; the yard case, whose profile quadrature gives
    m to rounding (118 999.999 kg for the hammer: before, "1.19e+05 outside [1.19e+05, 1.19e+05]"), is inside:
    its inverse estimates get the calibrated band."""
    write_calibration(calibration(masses={"hammer": (HAMMER, HAMMER), "anvil": (ANVIL, ANVIL)}), tmp_path / "cal.h5")
    case, output = case_naming(tmp_path, yard), tmp_path / "events.h5"
    result = CliRunner().invoke(main, ["run", str(case), "-o", str(output)])
    assert result.exit_code == 0, result.output
    with h5py.File(output, "r") as h5:
        estimates = [h5[f"events/{k}/inverse_rigid/c1"].attrs for k in h5["events"]]
        assert estimates and all(e["bound"] == "calibrated" and e["message"].startswith("calibrated peak error 95 % band") for e in estimates), \
            [e["message"] for e in estimates]


# -- a soft coupler ------------------------------------------------------------------------------


def soft_impact(folder: Path, **time: float) -> Path:
    """The default scene with a 1 kN/m Kelvin–Voigt coupler (contact time π√(M_eff/k) ≈ 23 s), rigid and coarse fem
    runs, through its measurement chain (1 kHz, 100 Hz low-pass)."""
    from femref.case.defaults import default_scene_data

    data = default_scene_data()
    data["couplers"][0]["law"] = {"kelvin_voigt": {"stiffness": 1.0e3, "damping": 1.0e2}}
    data.update(models=["fem", "rigid"], fem={"elements": 8, "order": 2}, estimators=[], time={"end": 0.5, **time})
    path = folder / "soft.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_a_soft_coupler_runs_its_rigid_model_below_the_chains_filter(tmp_path: Path) -> None:
    """Before, the rigid run stepped at end/20 = 25 ms (its contact time/100 is 0.23 s), a Nyquist frequency of
    20 Hz under the chain's 100 Hz filter: a ValueError traceback. The step rule keeps the filter's corner an
    octave below the stored samples' Nyquist frequency, dt = 1/(4 f_c) = 2.5 ms: 200 steps, and the run is ok."""
    output = tmp_path / "soft.h5"
    result = CliRunner().invoke(main, ["run", str(soft_impact(tmp_path)), "-o", str(output)])
    assert result.exit_code == 0, result.output
    with h5py.File(output, "r") as h5:
        rigid = h5["rigid"]
        assert rigid.attrs["status"] == "ok"
        settings = json.loads(rigid.attrs["settings"])
        assert settings["dt"] == pytest.approx(1.0 / (4.0 * 100.0)) and "measurement low-pass" in settings["dt_rule"], settings


def test_a_given_step_too_coarse_for_the_filter_is_a_case_error(tmp_path: Path) -> None:
    """time.dt = 10 ms stores samples whose Nyquist frequency (50 Hz) is below the 100 Hz filter: exit 2 at
    measurement.lowpass (before: the same ValueError traceback at run time)."""
    case = soft_impact(tmp_path, dt=0.01)
    result = CliRunner().invoke(main, ["validate", str(case)])
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    rule = "measurement.lowpass: must be below the Nyquist frequency 1/(2 time.dt × time.output_stride) = 50 Hz of the stored samples"
    assert f"{case}: {rule}" in " ".join(result.output.split()), result.output


# -- no local path in a report page -------------------------------------------------------------


def test_a_study_page_shows_no_local_path(tmp_path: Path) -> None:
    """The study page named the study file by the path it was given and showed the study's paths as written
    (a base case in another folder); now by name, or relative to the study file's folder."""
    folder = tmp_path / "runs" / "study"
    folder.mkdir(parents=True)
    with h5py.File(folder / "study.h5", "w") as h5:
        h5.attrs.update(study_yaml=f"base: {tmp_path}/cases/impact_free_roll.yaml\nnetworks: {{x: {{mlp: {{initial: {folder}/nets/x.npz}}}}}}\n",
                        femref_version="0")
        network = h5.create_group("networks/x")
        network.attrs.update(source="fem", network="mlp", validation_mean_error=0.01)
        network["loss_curve"] = np.array([1.0, 0.5])
    result = CliRunner().invoke(main, ["report", str(folder / "study.h5"), "-o", str(folder / "study.html")])
    assert result.exit_code == 0, result.output
    page = (folder / "study.html").read_text()
    assert str(tmp_path) not in page and "<td>study.h5</td>" in page
    assert "base: impact_free_roll.yaml" in page and "initial: nets/x.npz" in page


def test_a_folder_with_a_space_is_hidden_whole() -> None:
    """``/home/ann smith/yard/data/a.csv`` was shown as ``ann smith/yard/data/a.csv`` (the path cut at the space)."""
    from femref.report.html import hide_local_paths

    text = "- file: /home/ann smith/yard/data/a.csv\n- file: /srv/my runs/data/b.csv\nunits: m/s"
    assert hide_local_paths(text, Path("/srv/my runs")) == "- file: a.csv\n- file: data/b.csv\nunits: m/s"


def test_an_event_page_shows_no_local_path(tmp_path: Path) -> None:
    """An estimate's message and an event's flags may name a file by its absolute path (a network that gives the wrong
    number of values names its .npz): the event page shows it by name, or relative to the result file's folder."""
    from femref.report.measured import event_report

    result = tmp_path / "yard.h5"
    assert CliRunner().invoke(main, ["run", str(CASES / "measured_yard.yaml"), "-o", str(result)]).exit_code == 0
    with h5py.File(result, "r+") as h5:
        estimate = h5["events/0/kalman/c1"]
        estimate.attrs.update(status="failed", message="ValueError: /srv/yard data/networks/fem_mlp.npz gave 3 values, not 1")
        h5["events/0"].attrs["flags"] = json.dumps([f"saturated: {tmp_path}/records/hammer.csv 1.0–1.1 s"])
    with h5py.File(result, "r") as h5:
        page = event_report(result, h5)
    assert "/srv/yard data" not in page and str(tmp_path) not in page
    assert "failed: ValueError: fem_mlp.npz gave 3 values" in page and "saturated: records/hammer.csv" in page
