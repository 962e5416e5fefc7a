"""Model results and the HDF5 result file of docs/design.md §4, written atomically.

Layout::

    /                                attrs: femref_version, case_yaml, created
    /scene                           attrs: kind, epsilon, wave_travel_time, load_time (s), units (JSON)
    /<model>/                        attrs: status, message, wall_time_s, settings (JSON); a failed impact
                                     run keeps its histories up to the failing step (NaN after)
    /<model>/time | omega, lambda
    /<model>/probes/<probe>/acceleration, displacement (, axial_force; impacts: velocity, and on cars that
                                     bend vertical_* and pitch_* with pitch_rate)
    /<model>/couplers/<coupler>/force
    /<model>/couplers/<coupler>/peak_force   () N, network estimators (ann_<name>): the estimated peak, no time axis
    /<model>/energy/kinetic, strain, dissipated, external_work   (+ attr balance_error)
                                     impacts: kinetic, strain, body_dissipated, coupler_stored,
                                     coupler_dissipated, total
    /<model>/measured/time, /<model>/measured/<probe>/acceleration   (measurement chain)
    /<model>/measured/<probe>/vertical_acceleration, pitch_rate      (measurement chain, cars that bend)
    /<model>/fields/x, /<model>/fields/u   attrs: field_files (JSON: the XDMF + HDF5 field files' names → SHA-256)
    /<model>/<history group>/time    (omega, lambda) the model's axis, linked in as the group's coordinate
    /scores/<model>/                 attrs: reference, one per metric
    /choice/                         a model choice (femref run --tolerance; femref.choice.output)

The file is written under a temporary name in the target folder and renamed when
complete, so a crash never leaves a truncated file under the final name. Fields are
also written as an XDMF + HDF5 time series (meshio) that ParaView opens directly.

Publishing (issue 18). Every temporary is named ``.<final name>.femref-<pid>.tmp`` (a folder of
field files ``.<result name>.femref-<pid>.fields.tmp``) in the target folder, so a later write
of the same final name recognises the leftovers of a killed run and removes them
(:func:`remove_leftovers`; never those of a process still alive). The field files are written
first, their names and SHA-256 recorded in the result (attribute ``field_files`` of
``/<model>/fields``), then renamed into place, and the result file is renamed last: a kill
leaves either the previous pair or new field files beside the previous result, which
:func:`field_files_match` reports as not matching. The environment variable
``FEMREF_TEST_PAUSE_BEFORE_PUBLISH`` (seconds) is a test hook only: it sleeps between writing
the temporaries and the renames, so a test can kill a run there.

The output path (issue 18, before any work): :func:`check_output_path` is the rule every command
and :func:`femref.api.run_case` apply to where they write — its folder exists and is writable, a
file is not a folder, and neither it nor a file written beside it is an input — raising
:class:`OutputPathError` (a ``ValueError``; the command line's exit 2); :func:`clean_leftovers`
then removes the output's leftovers of killed and older runs (both below).

Older femref versions (before issue 18) named their temporaries at random: the result file
``.<final name>.<8 random characters>.tmp`` (``tempfile.mkstemp``) and a folder
``tmp<8 random characters>`` (``tempfile.mkdtemp``) holding the XDMF + HDF5 field files
``<result stem>_<model>_fields.xdmf|.h5``. Without a pid in the name, :func:`legacy_leftovers`
recognises them by name *and* content — a folder holding nothing but field files of this result
(HDF5 and XDMF by their first bytes), a file of this final name (an HDF5 file if it is one) —
owned by this user, unchanged for :data:`LEGACY_QUIET_SECONDS`, and open (or the working folder)
of no process (``/proc``). What fails only the last two conditions, or holds other files, is kept
and reported, never removed; without ``/proc`` nothing is removed.

Time axes as dimension scales, for xarray (``xarray.open_dataset(path, group="fem/probes/left",
engine="h5netcdf")`` gives ``time`` as the coordinate). Each history group (a probe's, a
coupler's, ``energy``) holds its model's axis as a hard link named ``time`` (harmonic runs:
``omega``, plus ``lambda`` as a second coordinate) to one HDF5 dimension scale attached to
its datasets; ``/<model>/measured/time`` is the measured histories' own scale, linked the
same way into ``/<model>/measured/<probe>``. The model-level ``/<model>/time`` stays a plain
copy: a scale there would be visible (netCDF-4 rules) in ``fields/`` and ``measured/``, whose
own differently sized ``time`` would then be misread and break ``xarray.open_datatree``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref import __version__
from femref.core.catalog import SCENE_GROUP

UNITS = {
    "time": "s",
    "omega": "rad/s",
    "lambda": "1",
    "acceleration": "m/s^2",
    "displacement": "m",
    "velocity": "m/s",
    "vertical_velocity": "m/s (up positive)",
    "pitch_rate": "rad/s (front rising positive)",
    "vertical_acceleration": "m/s^2 (up positive)",
    "vertical_displacement": "m (up positive)",
    "pitch_acceleration": "rad/s^2 (front rising positive)",
    "pitch_displacement": "rad (front rising positive)",
    "axial_force": "N (tension positive)",
    "force": "N (compression positive)",
    "peak_force": "N (compression positive)",
    "x": "m",
    "u": "m",
    "kinetic": "J",
    "strain": "J",
    "dissipated": "J",
    "external_work": "J",
    "body_dissipated": "J",
    "coupler_stored": "J",
    "coupler_dissipated": "J",
    "total": "J",
    "closure": "m (compression positive)",
}


#: The scores' attribute naming each undefined (NaN) metric and why: ``"<metric>: <reason>; …"``.
UNDEFINED = "undefined"
SCENE_UNITS = {"epsilon": "1", "wave_travel_time": "s", "load_time": "s"}


@dataclass
class ModelResult:
    """What every model returns to the runner: outputs, status and work counters."""

    model: str
    status: str = "ok"
    message: str = ""
    wall_time_s: float = 0.0
    settings: dict[str, Any] = field(default_factory=dict)
    axes: dict[str, NDArray] = field(default_factory=dict)  # "time" or "omega" and "lambda"
    probes: dict[str, dict[str, NDArray]] = field(default_factory=dict)
    couplers: dict[str, dict[str, NDArray]] = field(default_factory=dict)
    energy: dict[str, NDArray] = field(default_factory=dict)
    fields: dict[str, NDArray] = field(default_factory=dict)  # "x" (Nx,), "u" (Nt_out, Nx), "time"
    measured: dict[str, NDArray] = field(default_factory=dict)  # "time" and probe → measured acceleration
    measured_bending: dict[str, dict[str, NDArray]] = field(default_factory=dict)  # probe → measured vertical_acceleration, pitch_rate (cars that bend)

    @classmethod
    def failed(cls, model: str, message: str, wall_time_s: float = 0.0, settings: dict | None = None) -> "ModelResult":
        return cls(model=model, status="failed", message=message, wall_time_s=wall_time_s, settings=settings or {})

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def set_probe_outputs(self, probe_names, outputs: dict[str, NDArray]) -> None:
        """Store outputs of shape ``(N_axis, N_probes)`` as per-probe histories, keyed by probe name."""
        self.probes = {name: {k: v[:, j] for k, v in outputs.items()} for j, name in enumerate(probe_names)}


#: Test hook only (issue 18): seconds to sleep between writing a result's temporaries and renaming them.
TEST_PAUSE_VARIABLE = "FEMREF_TEST_PAUSE_BEFORE_PUBLISH"
#: Attribute of ``/<model>/fields``: JSON ``{field file name: SHA-256 hex digest}`` of its XDMF + HDF5 pair.
FIELD_FILES_ATTRIBUTE = "field_files"
#: Axis names: linked into every history group as coordinates (readers listing outputs skip them).
AXIS_NAMES = ("time", "omega", "lambda")

_TEMPORARY = re.compile(r"^\.(?P<final>.+)\.femref-(?P<pid>\d+)(?:-\d+)?(?:\.(?P<part>[a-z]+))?\.tmp$")


def temporary_path(path: str | Path, part: str = "") -> Path:
    """``.<name>.femref-<pid>[.<part>].tmp`` beside ``path``: the name a later run recognises as a leftover."""
    path = Path(path)
    return path.with_name(f".{path.name}.femref-{os.getpid()}" + (f".{part}" if part else "") + ".tmp")


def _create_temporary(path: Path, part: str = "", folder: bool = False) -> Path:
    """Create (exclusively) the temporary file or folder of ``path``; ``-<n>`` after the pid if taken."""
    base = temporary_path(path, part)
    for n in range(1, 1000):
        candidate = base if n == 1 else base.with_name(base.name.replace(f"-{os.getpid()}", f"-{os.getpid()}-{n}", 1))
        try:
            if folder:
                candidate.mkdir()
            else:
                os.close(os.open(candidate, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
            return candidate
        except FileExistsError:
            continue
    raise FileExistsError(f"{base}: no free temporary name")


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def leftovers(path: str | Path) -> list[Path]:
    """Temporaries of ``path``'s final name (files or folders) whose writing process is no longer alive."""
    path = Path(path)
    if not path.parent.is_dir():
        return []
    found = []
    for entry in path.parent.iterdir():
        match = _TEMPORARY.match(entry.name)
        if match and match["final"] == path.name and int(match["pid"]) != os.getpid() and not _process_alive(int(match["pid"])):
            found.append(entry)
    return sorted(found)


def remove_leftovers(path: str | Path) -> list[Path]:
    """Remove :func:`leftovers` of ``path`` (a killed run's temporaries); return what was removed."""
    removed = []
    for entry in leftovers(path):
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
        removed.append(entry)
    return removed


#: Seconds an older femref's temporary must be unchanged before :func:`remove_legacy_leftovers` removes it.
LEGACY_QUIET_SECONDS = 600.0
#: ``tempfile``'s random names: 8 characters of this alphabet.
_RANDOM = "[a-z0-9_]{8}"
_LEGACY_FOLDER = re.compile(rf"^tmp{_RANDOM}$")
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_XDMF_STARTS = (b"<Xdmf", b"<?xml")


@dataclass
class LegacyLeftovers:
    """An older femref's temporaries of one final name: those safe to remove, and those kept with the reason."""

    removable: list[Path] = field(default_factory=list)
    kept: list[tuple[Path, str]] = field(default_factory=list)


@dataclass
class LegacyCleanup:
    """What :func:`remove_legacy_leftovers` removed, and what it kept with the reason."""

    removed: list[Path] = field(default_factory=list)
    kept: list[tuple[Path, str]] = field(default_factory=list)


def legacy_leftovers(path: str | Path, now: float | None = None) -> LegacyLeftovers:
    """An older femref's temporaries of ``path`` (module docstring): ``tmp<random>`` folders of its field files and
    ``.<name>.<random>.tmp`` files, split into the removable ones (recognised by name and content, owned by this
    user, unchanged for :data:`LEGACY_QUIET_SECONDS` before ``now``, used by no process) and the kept ones (why)."""
    path = Path(path)
    found = LegacyLeftovers()
    if not path.parent.is_dir():
        return found
    now = time.time() if now is None else now
    own_file = re.compile(rf"^\.{re.escape(path.name)}\.{_RANDOM}\.tmp$")
    candidates = []
    for entry in sorted(path.parent.iterdir()):
        if _LEGACY_FOLDER.match(entry.name) and entry.is_dir() and not entry.is_symlink():
            problem, files = _legacy_folder_problem(entry, path)
        elif own_file.match(entry.name) and not entry.is_dir():
            problem, files = _legacy_file_problem(entry, path), [entry]
        else:
            continue
        if problem is None:  # not femref's at all: not ours to name
            continue
        if problem:
            found.kept.append((entry, problem))
        else:
            candidates.append((entry, files))
    if not candidates:
        return found
    in_use = _paths_in_use([entry for entry, _ in candidates])
    for entry, files in candidates:
        changed = now - max(item.lstat().st_mtime for item in [entry, *files])
        if in_use is None:
            found.kept.append((entry, "whether a process uses it cannot be checked here (no /proc)"))
        elif entry in in_use:
            found.kept.append((entry, "a running process uses it"))
        elif changed < LEGACY_QUIET_SECONDS:
            found.kept.append((entry, f"it changed {max(changed, 0.0):.0f} s ago"))
        else:
            found.removable.append(entry)
    return found


def remove_legacy_leftovers(path: str | Path) -> LegacyCleanup:
    """Remove the removable :func:`legacy_leftovers` of ``path``; return what was removed and what was kept."""
    found = legacy_leftovers(path)
    for entry in found.removable:
        if entry.is_dir():
            shutil.rmtree(entry, ignore_errors=True)  # checked: regular files only, no links to follow
        else:
            entry.unlink(missing_ok=True)
    return LegacyCleanup(found.removable, found.kept)


def _owned(entry: Path) -> bool:
    return not hasattr(os, "getuid") or entry.lstat().st_uid == os.getuid()


def _legacy_folder_problem(folder: Path, path: Path) -> tuple[str | None, list[Path]]:
    """Whether ``folder`` (named like ``tempfile.mkdtemp``'s) is an older femref's field-file folder of the result
    ``path``: None when it holds no field file of ``path`` (not femref's), ``""`` when it is one, else why it is
    not certain. Also its files."""
    try:
        files = sorted(folder.iterdir())
    except OSError:
        return None, []
    prefix, suffixes = f"{path.stem}_", ("_fields.xdmf", "_fields.h5")
    ours = [f for f in files if f.name.startswith(prefix) and f.name.endswith(suffixes) and len(f.name) > len(prefix) + len(suffixes[1])]
    if not ours:
        return None, files
    others = [f.name for f in files if f not in ours]
    if others:
        return f"it also holds {', '.join(others[:3])}{' …' if len(others) > 3 else ''}, which femref does not write there", files
    for file in files:
        if file.is_symlink() or not file.is_file():
            return f"{file.name} is not a regular file", files
        head = _head(file)
        if head and not head.startswith(HDF5_SIGNATURE if file.suffix == ".h5" else _XDMF_STARTS):
            return f"{file.name} is not {'an HDF5' if file.suffix == '.h5' else 'an XDMF'} file", files
    if not all(_owned(item) for item in [folder, *files]):
        return "it belongs to another user", files
    return "", files


def _legacy_file_problem(file: Path, path: Path) -> str:
    """Whether ``file`` (named ``.<path name>.<random>.tmp``) is an older femref's temporary of ``path``: ``""`` if so,
    else why it is not certain."""
    if file.is_symlink() or not file.is_file():
        return "it is not a regular file"
    if path.suffix == ".h5" and _head(file) and not _head(file).startswith(HDF5_SIGNATURE):
        return "it is not an HDF5 file"
    if not _owned(file):
        return "it belongs to another user"
    return ""


def _head(file: Path) -> bytes:
    """The first bytes of ``file`` (empty if it is empty or unreadable)."""
    try:
        with open(file, "rb") as stream:
            return stream.read(8)
    except OSError:
        return b""


def _paths_in_use(entries: list[Path]) -> set[Path] | None:
    """Those of ``entries`` (files or folders) that a process has open, or under its working folder (``/proc``);
    None where ``/proc`` cannot tell. Processes of other users, which ``/proc`` does not show, are not seen:
    :func:`legacy_leftovers` only considers this user's entries."""
    proc = Path("/proc")
    if not (proc / "self" / "fd").is_dir():
        return None
    targets = {entry: os.path.realpath(entry) for entry in entries}
    used: set[Path] = set()
    for process in proc.iterdir():
        if not process.name.isdigit():
            continue
        try:
            links = [os.readlink(process / "cwd")]
            links += [os.readlink(fd) for fd in (process / "fd").iterdir()]
        except OSError:  # ended, or another user's
            continue
        for entry, target in targets.items():
            if any(link == target or link.startswith(target + os.sep) for link in links):
                used.add(entry)
    return used


# --- the output path: the rule femref's commands and femref.api share ---------------------------------------------
#
# An output is checked before any work, so a bad path never costs a run and nothing is written: its folder must
# exist and be writable (a file output's parent, a folder output itself or its parent); a file output may not be a
# folder, a folder output not a file; neither the output nor any other file the writer puts beside it (``writes``:
# a sweep's ``.partial``, a run's field files, a study's networks) may be one of the writer's inputs — the same path,
# or the same file by another relative path, a symbolic or a hard link. The inputs are the files given to the writer
# and every file a case names (femref.case.inputs.case_inputs). The command line prints an OutputPathError as
# ``error: …`` and exits 2 (femref.cli.common.check_output); femref.api.run_case raises it.


class OutputPathError(ValueError):
    """An output path that cannot be written: ``<option> <path>: <rule>; nothing was written``.

    ``option`` names where the path came from (``-o``; ``-o (default)`` when it is the option's
    default; ``output`` for :func:`femref.api.run_case`), ``problem`` the rule it breaks
    (:func:`output_problem`).
    """

    def __init__(self, path: Path, option: str, problem: str, default: bool = False) -> None:
        self.path = Path(path)
        self.option = option
        self.problem = problem
        self.default = default
        named = f"{option} (default)" if default else option
        super().__init__(f"{named} {path}: {problem}; nothing was written")


def check_output_path(
    path: str | Path,
    option: str,
    inputs: Mapping[str, str | Path | None] | None = None,
    *,
    folder: bool = False,
    default: bool = False,
    writes: Iterable[str | Path] = (),
) -> None:
    """Raise :class:`OutputPathError` unless ``path`` can be written (:func:`output_problem`); write nothing.

    ``option`` names the option or argument (``-o``), ``default`` says the path is its default;
    ``inputs`` the writer's input files by name (``CASE``, ``loads.F2.csv.path of CASE``), which
    the output may not be; ``folder`` says the output is a folder; ``writes`` the other files the
    writer puts beside the output or in the output folder, which may not be inputs either.
    """
    problem = output_problem(Path(path), inputs or {}, folder, writes)
    if problem:
        raise OutputPathError(Path(path), option, problem, default)


def output_problem(path: Path, inputs: Mapping[str, str | Path | None], folder: bool = False, writes: Iterable[str | Path] = ()) -> str:
    """Why ``path`` cannot be the output, or ``""``: its folder must exist and be writable, a file output must not be
    a folder (a folder output not a file), and neither it nor a file of ``writes`` may be one of ``inputs`` (the same
    path, or the same file through another relative path, a symbolic or a hard link)."""
    path = Path(path)
    if folder:
        if path.exists() and not path.is_dir():
            return "is a file; the output is a folder"
        where = path if path.is_dir() else path.parent
    else:
        if path.is_dir():
            return "is a folder; the output is a file"
        where = path.parent
    if not where.exists():
        return f"the folder {where} does not exist (the output's folder must exist)"
    if not where.is_dir():
        return f"{where} is not a folder"
    if not os.access(where, os.W_OK | os.X_OK):
        return f"the folder {where} is not writable (the output's folder must be writable)"
    for name, given in inputs.items():
        if given is not None and same_file(path, Path(given)):
            return f"is the input {name} {given} (the output may not overwrite an input)"
    for written in writes:
        for name, given in inputs.items():
            if given is not None and same_file(Path(written), Path(given)):
                return f"would write {written}, which is the input {name} {given} (the output may not overwrite an input)"
    return ""


def same_file(a: Path, b: Path) -> bool:
    """``a`` and ``b`` are the same file: the same resolved path, or (both existing) the same inode (a hard link)."""
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # either does not exist
        return False


@dataclass
class LeftoverCleanup:
    """What :func:`clean_leftovers` did for one output: the temporaries it removed — a killed run's (``killed``),
    an older femref's (``legacy``) — and those it kept with the reason (``kept``: not certainly unused)."""

    killed: list[Path] = field(default_factory=list)
    legacy: list[Path] = field(default_factory=list)
    kept: list[tuple[Path, str]] = field(default_factory=list)


def clean_leftovers(path: str | Path) -> LeftoverCleanup:
    """Remove the temporaries of ``path`` that no running process writes — a killed run's (pid-named,
    :func:`remove_leftovers`) and an older femref's (``tmp*`` field-file folders,
    ``.<name>.<random>.tmp`` files: :func:`remove_legacy_leftovers`); return what was removed
    and what was kept (an older femref's temporary that is not certainly unused, or holds more than femref wrote)."""
    killed = remove_leftovers(path)
    legacy = remove_legacy_leftovers(path)
    return LeftoverCleanup(killed, legacy.removed, legacy.kept)


def field_file_paths(output: str | Path, models: Sequence[str]) -> list[Path]:
    """The field files a result file ``output`` gets beside it for each of ``models`` that writes fields:
    ``<stem>_<model>_fields.xdmf`` and its HDF5 companion ``<stem>_<model>_fields.h5``
    (:func:`field_file_name`; meshio names the companion after the XDMF file)."""
    output = Path(output)
    pairs = [output.with_name(field_file_name(output, model)) for model in models]
    return [file for xdmf in pairs for file in (xdmf, xdmf.with_suffix(".h5"))]


def result_field_files(results: str | Path, name: str = "RESULTS.h5") -> dict[str, Path]:
    """The field files of the result file ``results`` as inputs for :func:`check_output_path`, keyed
    ``XDMF field file of model <model> of <name>`` (``HDF5 field file …``): the names it records (attribute
    ``field_files`` of ``/<model>/fields``) and, for a model with fields that records none (a file written before
    the names were recorded), the names femref gives them (:func:`field_file_paths`). Empty for a file without
    fields. Raises ``OSError`` when ``results`` is not a readable HDF5 file."""
    results = Path(results)
    found: dict[str, Path] = {}
    with h5py.File(results, "r") as h5:
        for model, group in h5.items():
            if not (isinstance(group, h5py.Group) and isinstance(group.get("fields"), h5py.Group)):
                continue
            try:
                names = sorted(dict(json.loads(group["fields"].attrs[FIELD_FILES_ATTRIBUTE])))
            except (KeyError, TypeError, ValueError):  # none recorded (or unreadable): the names femref gives them
                names = [path.name for path in field_file_paths(results, [model])]
            for file in names:
                kind = {".xdmf": "XDMF field file", ".h5": "HDF5 field file"}.get(Path(file).suffix, f"field file {file}")
                found[f"{kind} of model {model} of {name}"] = results.parent / file
    return found


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write; renamed to ``path`` when the block ends without error.

    On any error (or interrupt) the temporary file is removed, so nothing is ever left
    under the final name half-written (docs/design.md §4); a kill leaves the temporary
    (:func:`temporary_path`), which the next write of ``path`` removes. The file gets the
    permissions of a newly created file (umask). Creates the folder.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(path)
    tmp = _create_temporary(path)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_results(
    path: str | Path,
    case_yaml: str,
    results: list[ModelResult],
    scores: dict[str, dict[str, Any]] | None = None,
    extra: Callable[[h5py.File], None] | None = None,
    scene: dict[str, Any] | None = None,
) -> list[Path]:
    """Write the result file (and XDMF field files) atomically; return the paths written.

    The field files are written first under temporary names, their SHA-256 recorded in the
    result, and renamed into place before the result file is (module docstring).

    ``scene`` holds the facts of the resolved scene the report shows (kind, ε and the times it
    is made of: ``Scene.facts()``), written as attributes of ``/scene`` with units. ``extra(h5)``
    adds groups of its own (e.g. ``/choice``) before the file is renamed.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(path)
    with contextlib.ExitStack() as cleanup:
        staged: dict[str, list[Path]] = {}
        if any(result.fields for result in results):
            staging = _create_temporary(path, part="fields", folder=True)
            cleanup.callback(shutil.rmtree, staging, True)
            for result in results:
                if result.fields:
                    staged[result.model] = _write_xdmf_pair(staging, field_file_name(path, result.model), result.fields)
        published = []
        with atomic_path(path) as tmp_name:
            with h5py.File(tmp_name, "w") as h5:
                h5.attrs["femref_version"] = __version__
                h5.attrs["case_yaml"] = case_yaml
                h5.attrs["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
                if scene:
                    group = h5.create_group(SCENE_GROUP)
                    for key, value in scene.items():
                        group.attrs[key] = value
                    group.attrs["units"] = json.dumps({key: SCENE_UNITS[key] for key in scene if key in SCENE_UNITS})
                for result in results:
                    _write_model(h5.create_group(result.model), result)
                    if result.model in staged:
                        digests = {file.name: _sha256(file) for file in staged[result.model]}
                        h5[f"{result.model}/fields"].attrs[FIELD_FILES_ATTRIBUTE] = json.dumps(digests, sort_keys=True)
                for model, metrics in (scores or {}).items():
                    group = h5.require_group(f"scores/{model}")
                    for key, value in metrics.items():
                        group.attrs[key] = value
                if extra is not None:
                    extra(h5)
            _test_pause()
            for files in staged.values():  # the field files first, the result (on leaving the block) last
                published += _publish(files, path.parent)
    return [path, *published]


def field_file_name(path: str | Path, model: str) -> str:
    """The XDMF field file of ``model`` beside the result file ``path``: ``<stem>_<model>_fields.xdmf``."""
    return f"{Path(path).stem}_{model}_fields.xdmf"


def field_files_match(path: str | Path) -> list[str]:
    """Problems of the field files recorded in the result file ``path``: missing, or not the ones it was written with.

    Empty when every recorded file is beside ``path`` with its recorded SHA-256 (and for a
    file that records none, written before issue 18). A field file that does not match was
    left by another run (e.g. the next run killed between publishing its field files and its
    result): the result's own ``/<model>/fields`` stays right, the ParaView files do not.
    """
    path = Path(path)
    problems = []
    with h5py.File(path, "r") as h5:
        recorded = {
            model: group["fields"].attrs[FIELD_FILES_ATTRIBUTE]
            for model, group in h5.items()
            if isinstance(group, h5py.Group) and isinstance(group.get("fields"), h5py.Group) and FIELD_FILES_ATTRIBUTE in group["fields"].attrs
        }
    for model, text in recorded.items():
        try:
            digests = dict(json.loads(text))
        except (TypeError, ValueError):
            problems.append(f"{path}: /{model}/fields attribute {FIELD_FILES_ATTRIBUTE} is not a JSON object of file names and SHA-256")
            continue
        for name, digest in sorted(digests.items()):
            file = path.parent / name
            if not file.is_file():
                problems.append(f"{file}: field file of model {model} missing")
            elif _sha256(file) != digest:
                problems.append(f"{file}: field file of model {model} is not the one {path.name} was written with (SHA-256 differs): another run's")
    return problems


def _sha256(file: Path) -> str:
    digest = hashlib.sha256()
    with open(file, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _test_pause() -> None:
    """Test hook only: sleep ``$FEMREF_TEST_PAUSE_BEFORE_PUBLISH`` seconds (unset: none) before the renames."""
    seconds = os.environ.get(TEST_PAUSE_VARIABLE)
    if seconds:
        time.sleep(float(seconds))


def _publish(files: list[Path], folder: Path) -> list[Path]:
    """Rename each of ``files`` (in a staging folder on the same file system) into ``folder``."""
    moved = []
    for file in files:
        target = folder / file.name
        os.replace(file, target)
        moved.append(target)
    return moved


def _dataset(group: h5py.Group, name: str, data: NDArray) -> h5py.Dataset:
    ds = group.create_dataset(name, data=np.asarray(data))
    if name in UNITS:
        ds.attrs["units"] = UNITS[name]
    return ds


def _write_model(group: h5py.Group, result: ModelResult) -> None:
    group.attrs["status"] = result.status
    group.attrs["message"] = result.message
    group.attrs["wall_time_s"] = float(result.wall_time_s)
    group.attrs["settings"] = json.dumps(result.settings, default=_json_default, sort_keys=True)
    for name, axis in result.axes.items():
        _dataset(group, name, axis)
    histories = []
    for probe, outputs in result.probes.items():
        histories.append(sub := group.require_group(f"probes/{probe}"))
        for name, data in outputs.items():
            _dataset(sub, name, data)
    for coupler, outputs in result.couplers.items():
        histories.append(sub := group.require_group(f"couplers/{coupler}"))
        for name, data in outputs.items():
            _dataset(sub, name, data)
    if result.energy:
        histories.append(sub := group.create_group("energy"))
        for name, data in result.energy.items():
            _dataset(sub, name, data)
        if "energy_balance_error" in result.settings:
            sub.attrs["balance_error"] = float(result.settings["energy_balance_error"])
    axis = next((name for name in ("time", "omega") if name in result.axes), None)
    if axis is not None:
        extra = {"lambda": result.axes["lambda"]} if axis == "omega" and "lambda" in result.axes else {}
        _link_axis(histories, axis, result.axes[axis], extra)
    if result.measured:
        sub = group.create_group("measured")
        for name, data in result.measured.items():
            if name == "time":
                _dataset(sub, "time", data)
            else:
                _dataset(sub.require_group(name), "acceleration", data)
        for name, outputs in result.measured_bending.items():
            for quantity, data in outputs.items():
                _dataset(sub.require_group(name), quantity, data)
        if "time" in sub:
            probes = [sub[name] for name in list(result.measured) + list(result.measured_bending) if name != "time"]
            _link_axis(list({g.name: g for g in probes}.values()), "time", sub["time"], {}, scale=sub["time"])
    if result.fields:
        sub = group.create_group("fields")
        for name, data in result.fields.items():
            _dataset(sub, name, data)
        if {"x", "u", "time"} <= sub.keys() and sub["u"].shape == (len(sub["time"]), len(sub["x"])):
            for axis, name in enumerate(("time", "x")):  # the field's own axes (its times are a subset)
                sub[name].make_scale(name)
                sub["u"].dims[axis].attach_scale(sub[name])


def _link_axis(groups: list[h5py.Group], name: str, values, extra: dict[str, NDArray], scale: h5py.Dataset | None = None) -> None:
    """Make ``values`` the dimension scale ``name`` of the first axis of every dataset in ``groups`` that runs along
    it, and link it (and the ``extra`` coordinates, e.g. ``lambda`` beside ``omega``) into each such group.

    One scale object, hard-linked under ``name`` into every group: xarray (h5netcdf, netCDF4) opens
    any one group with the axis as its coordinate, and the data is stored once. ``scale`` is an
    existing dataset to use (the measured ``time``); else the first group gets a new one.
    """
    size = len(values)
    coordinates: dict[str, h5py.Dataset] = {}
    for group in groups:
        along = [ds for key, ds in group.items() if isinstance(ds, h5py.Dataset) and key not in AXIS_NAMES and ds.ndim >= 1 and ds.shape[0] == size]
        if not along:
            continue
        if scale is None:
            scale = _dataset(group, name, values)
        if not scale.is_scale:
            scale.make_scale(name)
        if name not in group:
            group[name] = scale
        for coordinate, data in extra.items():
            if coordinate not in coordinates:
                coordinates[coordinate] = _dataset(group, coordinate, data)
                coordinates[coordinate].dims[0].attach_scale(scale)
            elif coordinate not in group:
                group[coordinate] = coordinates[coordinate]
        for ds in along:
            ds.dims[0].attach_scale(scale)
            if extra:
                ds.attrs["coordinates"] = " ".join(extra)


def _write_xdmf_pair(folder: Path, name: str, fields: dict[str, NDArray]) -> list[Path]:
    """Write the XDMF + HDF5 time series of the displacement field on the 1D mesh (points padded to 3D: meshio
    and VTK need three components) as the file ``name`` and its companion into ``folder``; return both paths."""
    import meshio

    x, u, times = fields["x"], fields["u"], fields["time"]
    points = np.zeros((x.size, 3))
    points[:, 0] = x
    cells = [("line", np.stack([np.arange(x.size - 1), np.arange(1, x.size)], axis=1))]
    before = set(folder.iterdir())
    # meshio opens the companion .h5 relative to the working directory: write from inside the folder
    with contextlib.chdir(folder), meshio.xdmf.TimeSeriesWriter(name) as writer:
        writer.write_points_cells(points, cells)
        for t, values in zip(times, u):
            writer.write_data(float(t), point_data={"u": np.asarray(values, dtype=float)})
    return sorted(set(folder.iterdir()) - before)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)
