"""Hostile and broken network files (issue 18): refused before anything large is allocated.

Every probe writes a valid small network file with ``ann.storage`` and then breaks it the way
a hostile or damaged file would — an ``.npy`` header that asks numpy for terabytes, a member the
zip directory declares at 2 GB, an unknown member, a NaN or infinite weight, shapes that do not
fit together, a truncated or corrupt archive, a pickled object, metadata nested past the JSON
reader's stack. ``femref run`` on a case naming the file must exit 2 with the file's problem
at ``estimators[1].network`` and write nothing; none of the probes allocates more than a few
kB (the point is that they are refused from the headers). A network whose finite weights
overflow to an infinite force is not a bad file but a failed estimate: status failed, exit 1.
"""

from __future__ import annotations

import io
import re
import struct
import warnings
import zipfile
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from numpy.lib import format as npy_format

import ann.storage as storage
from ann.features import FeaturePipeline, FeatureSettings
from ann.networks import MomentumMLP, RBFNetwork
from femref.cli import main
from femref.sensing.network import NetworkFileError, read_network
from femref.sensing.records import record_rate
from support.network_case import PROBES, RECORD_END, RECORD_LENGTH, TWO_CARS
from support.paths import CASES

RATE = record_rate(RECORD_LENGTH, RECORD_END)

#: A two-car free-roll impact on a coarse fem mesh, its model records read by a network.
CASE: dict[str, Any] = {
    **TWO_CARS,
    "time": {"end": RECORD_END},
    "models": ["fem"],
    "fem": {"elements": 8, "order": 1},
    "estimators": ["inverse_rigid", {"name": "ann_x", "network": "net.npz"}],
}
METADATA: dict[str, Any] = {
    "target": "peak_coupler_force",
    "coupler": "c1",
    "probes": PROBES,
    "record_length": RECORD_LENGTH,
    "record_end": RECORD_END,
    "record_source": "model",
    "measurement": None,
}
NETWORK = "estimators[1].network"
UNUSABLE = r"not a usable ann network file \(ann\.storage \.npz\): \S+net\.npz: "


@pytest.fixture(scope="module")
def parts() -> tuple[FeaturePipeline, RBFNetwork, MomentumMLP]:
    """A pipeline (4 channels × 64 samples → 8 samples each, 32 features) fitted on seeded random
    records, and a 4-centre RBF network and a 32-3-1 momentum MLP fitted on random targets: their
    predictions mean nothing, their files are valid."""
    rng = np.random.default_rng(18)
    records = rng.normal(size=(12, len(PROBES), RECORD_LENGTH))
    pipeline = FeaturePipeline(FeatureSettings(length=8, rate=RATE)).fit(records, RATE)
    X, y = pipeline.transform(records, RATE), rng.uniform(1.0e6, 2.0e6, size=12)
    rbf = RBFNetwork(centres=4, seed=0).fit(X, y)
    mlp = MomentumMLP(hidden=(3,), epochs=3, tol=None, seed=0).fit(X, y)
    return pipeline, rbf, mlp


# -- writing broken files -------------------------------------------------------------------


def _arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {key: data[key] for key in data.files}


def _savez(path: Path, arrays: dict[str, np.ndarray]) -> None:
    with open(path, "wb") as handle:
        np.savez(handle, **arrays)


def edited(network: str = "rbf", **changes: Any) -> Callable[[Path, Any], None]:
    """A writer: the valid file of ``network`` with arrays replaced, added (``name=value``) or removed (None).

    Keys use ``__`` for ``/`` (``network__weights``); a callable value gets the old array.
    """

    def write(path: Path, parts) -> None:
        pipeline, rbf, mlp = parts
        storage.save(path, pipeline, {"rbf": rbf, "mlp": mlp}[network], METADATA)
        arrays = _arrays(path)
        for key, value in changes.items():
            key = key.replace("__", "/")
            if value is None:
                del arrays[key]
            else:
                arrays[key] = value(arrays[key]) if callable(value) else value
        _savez(path, arrays)

    return write


def _with(values: np.ndarray, index: int, value: float) -> np.ndarray:
    values = values.copy()
    values.flat[index] = value
    return values


def _members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as archive:
        return {info.filename: archive.read(info) for info in archive.infolist()}


def _rezip(path: Path, members: dict[str, bytes]) -> None:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as archive:
        for name, data in members.items():
            archive.writestr(name, data)


def forged_shape(shape: tuple[int, ...], member: str = "network/weights.npy") -> Callable[[Path, Any], None]:
    """A valid file whose ``member`` keeps its data under a rewritten ``.npy`` header declaring ``shape``."""

    def write(path: Path, parts) -> None:
        edited()(path, parts)
        members = _members(path)
        stream = io.BytesIO(members[member])
        version = npy_format.read_magic(stream)
        _, fortran_order, dtype = npy_format.read_array_header_1_0(stream) if version == (1, 0) else npy_format.read_array_header_2_0(stream)
        data = members[member][stream.tell() :]
        header = io.BytesIO()
        npy_format.write_array_header_1_0(header, {"descr": npy_format.dtype_to_descr(dtype), "fortran_order": fortran_order, "shape": shape})
        members[member] = header.getvalue() + data
        _rezip(path, members)

    return write


def declared_size(member: str, size: int) -> Callable[[Path, Any], None]:
    """A valid file plus a small ``member`` whose zip directory entry declares ``size`` bytes uncompressed."""

    def write(path: Path, parts) -> None:
        edited()(path, parts)
        members = _members(path)
        members[member] = members["network/weights.npy"]
        _rezip(path, members)
        data = bytearray(path.read_bytes())
        end = data.rfind(b"PK\x05\x06")  # end of central directory: its offset at +16
        (at,) = struct.unpack_from("<I", data, end + 16)
        while data[at : at + 4] == b"PK\x01\x02":
            name_length, extra_length, comment_length = struct.unpack_from("<HHH", data, at + 28)
            if data[at + 46 : at + 46 + name_length].decode() == member:
                struct.pack_into("<I", data, at + 24, size)  # uncompressed size
            at += 46 + name_length + extra_length + comment_length
        path.write_bytes(bytes(data))

    return write


def truncated(path: Path, parts) -> None:
    edited()(path, parts)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def corrupt_member(path: Path, parts) -> None:
    """A data byte of network/weights flipped: the zip's CRC no longer matches."""
    edited()(path, parts)
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo("network/weights.npy")
    data = bytearray(path.read_bytes())
    name_length, extra_length = struct.unpack_from("<HH", data, info.header_offset + 26)
    last = info.header_offset + 30 + name_length + extra_length + info.file_size - 1
    data[last] ^= 0xFF
    path.write_bytes(bytes(data))


def not_npy(path: Path, parts) -> None:
    edited()(path, parts)
    members = _members(path)
    members["network/weights.npy"] = b"GIF89a not an array at all"
    _rezip(path, members)


def pickled_object(path: Path, parts) -> None:
    """network/basis stored as a pickled object array (np.savez pickles object arrays unless told not to)."""
    edited()(path, parts)
    arrays = _arrays(path)
    arrays["network/basis"] = np.array("gaussian", dtype=object)
    _savez(path, arrays)


#: id → (writer, message after "<case>: estimators[1].network: " (a regex)).
HOSTILE: dict[str, tuple[Callable[[Path, Any], None], str]] = {
    "header asks for 7 TiB": (
        forged_shape((1_048_576, 917_504)),
        UNUSABLE + r"member network/weights: its header declares shape \(1048576, 917504\), more than 33554432 values \(refused unread\)",
    ),
    "header asks for more than the member holds": (
        forged_shape((6,)),
        UNUSABLE + r"member network/weights: its header declares shape \(6,\) of <f8 \(48 bytes\), but the member holds 40 bytes of data \(refused unread\)",
    ),
    "member declared at 2 GB": (
        declared_size("network/weights_2.npy", 2**31),
        UNUSABLE + r"its members declare \d+ bytes uncompressed, more than the 268435456 bytes an ann model file may hold \(refused unread\)",
    ),
    "unknown member": (
        edited(smuggled=np.zeros(3)),
        UNUSABLE + r"unknown member\(s\) smuggled\.npy; an ann model file of kind rbf holds only format_version, network_kind, metadata "
        r"and its pipeline/ and network/ arrays \(refused unread\)",
    ),
    "NaN weight": (edited(network__weights=lambda w: _with(w, 2, np.nan)), UNUSABLE + r"network/weights holds 1 non-finite value\(s\) \(NaN or infinity\)"),
    "inf weight": (edited(network__weights=lambda w: _with(w, 0, -np.inf)), UNUSABLE + r"network/weights holds 1 non-finite value\(s\) \(NaN or infinity\)"),
    "inf centre": (edited(network__centres=lambda c: _with(c, 5, np.inf)), UNUSABLE + r"network/centres holds 1 non-finite value\(s\)"),
    "NaN width": (edited(network__width=np.array(np.nan)), UNUSABLE + r"network/width holds 1 non-finite value\(s\)"),
    "NaN scaler": (edited(pipeline__scale=lambda s: _with(s, 7, np.nan)), UNUSABLE + r"pipeline/scale holds 1 non-finite value\(s\)"),
    "NaN MLP bias": (edited("mlp", network__intercept_1=lambda b: _with(b, 0, np.nan)), UNUSABLE + r"network/intercept_1 holds 1 non-finite value\(s\)"),
    "weights of the wrong length": (
        edited(network__weights=lambda w: w[:-1]),
        UNUSABLE + r"network/weights has shape \(4,\), but 4 centres and the constant make 5 rows",
    ),
    "centres of the wrong feature count": (
        edited(network__centres=lambda c: c[:, :-1]),
        UNUSABLE + r"network/centres has shape \(4, 31\); an RBF network of 32 features needs \(centres >= 2, 32\)",
    ),
    "scaler of the wrong length": (
        edited(pipeline__mean=lambda m: m[:-1]),
        UNUSABLE + r"pipeline/mean has shape \(31,\), but 4 channels resampled to 8 samples .* makes it \(32,\)",
    ),
    "MLP layers that do not chain": (
        edited("mlp", network__coef_1=np.zeros((4, 1))),
        UNUSABLE + r"network/coef_1 has shape \(4, 1\), but layer 0 of 3 makes it \(3, 1\)",
    ),
    "MLP layer missing": (edited("mlp", network__coef_1=None), UNUSABLE + r"network/layers is 2, but the file has no network/coef_1"),
    "MLP layer beyond its layers": (edited("mlp", network__coef_7=np.zeros((3, 1))), UNUSABLE + r"network/layers is 2, but the file also has network/coef_7"),
    "records of a billion samples": (
        edited(pipeline__samples=np.array(10**9)),
        UNUSABLE + r"pipeline records of 4 channels × 1000000000 samples exceed 16777216 values per record",
    ),
    "truncated archive": (truncated, UNUSABLE + r"not a readable zip archive \(\.npz\): File is not a zip file"),
    "corrupt member (bad CRC)": (corrupt_member, UNUSABLE + r"not a readable zip archive \(\.npz\): Bad CRC-32 for file 'network/weights\.npy'"),
    "member not an .npy array": (not_npy, UNUSABLE + r"member network/weights is not a readable \.npy array: "),
    "pickled object member": (pickled_object, UNUSABLE + r"member network/basis: dtype \|O is not a text array"),
    "metadata nested past the JSON reader": (edited(metadata=np.array("[" * 100_000)), UNUSABLE + "metadata is JSON nested too deeply to read"),
    "metadata not JSON": (edited(metadata=np.array("{target: peak")), UNUSABLE + "metadata is not JSON text: "),
}


def write_case(directory: Path, data: dict[str, Any] | None = None) -> Path:
    path = directory / "case.yaml"
    path.write_text(yaml.safe_dump(data or CASE, sort_keys=False))
    return path


@pytest.mark.parametrize(("writer", "rule"), list(HOSTILE.values()), ids=list(HOSTILE))
def test_hostile_network_file_exits_2_at_the_estimator_and_writes_nothing(parts, tmp_path: Path, writer, rule: str) -> None:
    writer(tmp_path / "net.npz", parts)
    path = write_case(tmp_path)
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(output)])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert re.search(rf"{re.escape(f'{path}: {NETWORK}: ')}{rule}", result.output), result.output
    assert not output.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["case.yaml", "net.npz"]


@pytest.mark.parametrize("writer", [HOSTILE["header asks for 7 TiB"][0], HOSTILE["NaN weight"][0], HOSTILE["unknown member"][0]],
                         ids=["7 TiB header", "NaN weight", "unknown member"])
def test_storage_and_read_network_raise_their_own_errors(parts, tmp_path: Path, writer) -> None:
    """``ann.storage`` raises ModelFileError (a ValueError, naming the file); femref's reader a NetworkFileError."""
    path = tmp_path / "net.npz"
    writer(path, parts)
    with pytest.raises(storage.ModelFileError, match=re.escape(str(path))):
        storage.load(path)
    with pytest.raises(NetworkFileError):
        read_network(path)


def test_valid_files_of_every_kind_pass_the_checks(parts, tmp_path: Path) -> None:
    """The checks refuse nothing ``ann.storage.save`` writes: both networks load and predict as saved."""
    pipeline, rbf, mlp = parts
    records = np.random.default_rng(1).normal(size=(3, len(PROBES), RECORD_LENGTH))
    for network in (rbf, mlp):
        path = tmp_path / f"{network.kind}.npz"
        storage.save(path, pipeline, network, METADATA)
        estimator, metadata = storage.load_estimator(path)
        assert metadata == METADATA
        np.testing.assert_array_equal(estimator.predict(records, RATE), storage.Estimator(pipeline, network).predict(records, RATE))


@pytest.mark.parametrize("kind", ["rbf", "mlp"])
def test_every_member_save_writes_is_a_declared_member(parts, tmp_path: Path, kind: str) -> None:
    """The member lists of ``ann.storage`` cover what each network's ``to_arrays`` writes (no valid file is refused by name)."""
    pipeline, rbf, mlp = parts
    network = {"rbf": rbf, "mlp": mlp}[kind]
    fixed, per_layer = storage._members_of(network.kind)
    written = ["format_version", "network_kind", "metadata", *(f"pipeline/{k}" for k in pipeline.to_arrays()), *(f"network/{k}" for k in network.to_arrays())]
    undeclared = [k for k in written if k not in fixed and not any(re.fullmatch(re.escape(p) + "[0-9]+", k) for p in per_layer)]
    assert undeclared == []


def test_a_study_initial_network_goes_through_the_same_checks(parts, tmp_path: Path) -> None:
    """``femref study`` reads an ``initial:`` network with ``ann.storage`` too: a NaN weight is exit 2 at
    ``networks.<name>.mlp.initial``, before any sweep runs or anything is written."""
    edited("mlp", network__coef_0=lambda w: _with(w, 0, np.nan))(tmp_path / "bad.npz", parts)
    data = yaml.safe_load((CASES / "studies" / "ann_study.yaml").read_text())
    data["base"] = str(CASES / "impact_free_roll.yaml")
    deep = {"hidden": [6, 3], "activation": ["tanh", "tanh", "logistic"], "solver": "momentum", "learning_rate": 0.05, "max_iter": 200}
    data["networks"] = {"x": {"mlp": {**deep, "initial": "bad.npz"}}}
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    result = CliRunner().invoke(main, ["study", str(path), "-o", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert re.search(rf"{re.escape(f'{path}: networks.x.mlp.initial: ')}.*network/coef_0 holds 1 non-finite value\(s\) \(NaN or infinity\)", result.output), result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.npz", "study.yaml"]


# A network that overflows is a failed estimate, not a bad file


def overflowing(path: Path, parts) -> None:
    """Finite weights of 1e308 on multiquadric bases (each ≥ 1): the sum of five overflows to +inf."""
    edited(network__basis=np.array("multiquadric"), network__weights=lambda w: np.full_like(w, 1.0e308))(path, parts)


def test_non_finite_estimates_are_failed_results(parts, tmp_path: Path, monkeypatch) -> None:
    """The network's infinite peak and an inverse estimator's NaN force history (a stand-in estimator)
    are failed results with the reason; the run exits 1 (a model failed) and still writes its file."""
    from femref.estimators import inverse

    overflowing(tmp_path / "net.npz", parts)
    monkeypatch.setitem(inverse.ESTIMATORS, "inverse_rigid", lambda scene, t, records: {"c1": np.where(t > 0.1, np.nan, 0.0)})
    output = tmp_path / "out.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the overflow itself
        result = CliRunner().invoke(main, ["run", str(write_case(tmp_path)), "-o", str(output)])
    assert result.exit_code == 1, result.output
    text = " ".join(result.output.split())
    assert re.search(r"model ann_x\W.*the estimate is not finite \(NaN or infinity\): c1 peak_force \(1 value\(s\)\)", text), result.output
    assert re.search(r"model inverse_rigid\W.*the estimate is not finite \(NaN or infinity\): c1 force \(\d+ value\(s\) from sample \d+ of \d+\)", text), result.output
    import h5py

    with h5py.File(output, "r") as h5:
        statuses = {name: h5[name].attrs["status"] for name in ("ann_x", "inverse_rigid", "fem") if name in h5}
    assert statuses == {"ann_x": "failed", "inverse_rigid": "failed", "fem": "ok"}, statuses


def test_a_measured_cases_non_finite_inverse_estimate_is_failed(monkeypatch) -> None:
    """In a measured case too (the same :func:`femref.estimators.capture`): an inverse estimator whose force history holds a NaN
    (a stand-in estimator) gives a failed estimate with no number, never an ok one."""

    from femref.estimators import InverseEstimator, Recorded, capture, inverse

    t = np.linspace(0.0, 1.0, 11)
    monkeypatch.setitem(inverse.ESTIMATORS, "inverse_rigid", lambda scene, t, records: {"c1": np.where(t > 0.45, np.inf, 1.0e5)})
    (estimate,) = capture(InverseEstimator("inverse_rigid"), Recorded(t, {}, [], []))
    assert (estimate.status, estimate.ok) == ("failed", False)
    assert estimate.message == "the inverse_rigid force is not finite (NaN or infinity) at 6 of 11 samples, from t = 0.5 s"
    assert np.all(np.isnan(estimate.force)) and np.all(np.isnan(estimate.peak))
