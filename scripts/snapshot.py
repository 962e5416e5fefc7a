"""Behaviour snapshot: prove that a refactor moved no number (issue 29, "No number moves").

Usage (from the repository root, with the project's environment)::

    .venv/bin/python scripts/snapshot.py take DIR [--only NAME ...] [--no-gallery]
    .venv/bin/python scripts/snapshot.py compare A B [--rtol 1e-10]

A snapshot of another commit (the one before a refactor) without touching the checkout: export it and
put its packages first on the path (they then shadow the editable install)::

    git archive HEAD | tar -x -C /tmp/before && cp scripts/snapshot.py /tmp/before/scripts/
    PYTHONPATH=/tmp/before .venv/bin/python /tmp/before/scripts/snapshot.py take build/before

``take DIR`` runs every case ``cases/*.yaml`` (measured cases included) through the command line's
own code path — ``femref run CASE -o DIR/<name>.h5``, invoked in this process through click, as
tests/examples/test_cases.py does — so ``DIR`` holds each result file, its field files
(``<name>_<model>_fields.xdmf/.h5``) and, in ``logs/``, what the command printed. It then imports
every gallery script ``docs/examples/*.py`` the way tests/examples/test_gallery.py does (each
computes its numbers at import) and writes each module's ``headline`` dict to ``DIR/gallery.json``.
One run more goes through the model-choice flow, which no case file selects: ``femref run
cases/impact_free_roll.yaml --tolerance 0.002 -o DIR/impact_free_roll_tolerance.h5`` (it climbs four rungs
of the ladder in well under a second; ``EXTRA_RUNS``). ``DIR/snapshot.json`` records the checkout the
snapshot was taken in and how long each step took (never compared itself). Sweep and study files (``cases/sweeps/``, ``cases/studies/``) are not cases and are not
run: a sweep runs 20 fem impacts through dask workers and a study trains networks, and their samples go
through the same runner as the cases.

The BLAS thread count is pinned to one (``OPENBLAS_NUM_THREADS`` etc., as ``make test`` does) before
numpy is imported: a multi-threaded BLAS may sum in a different order from run to run, which moves
last bits.

``compare A B`` pairs the files of the two folders by name (a file in only one is a difference) and
walks every group, dataset and attribute of each pair of HDF5 files, and every headline of
``gallery.json``; ``.xdmf`` field-file indexes (file names and the fields' times as text) exactly. Rules:

* numbers (datasets and attributes; integer, real and complex): the largest ``|a − b|`` over the
  finite entries, relative to the larger of the two arrays' max ``|value|``, must be ≤ ``rtol``; NaN and
  ±inf must sit at the same places; an all-zero array must stay exactly zero; shape and dtype must
  match. A scalar is its own max, so a headline or a scalar attribute is held to ``rtol`` of itself.
* strings, booleans and byte strings: exactly (``case_yaml``, ``status``, ``message``, units, ...).
* JSON attributes (a string that parses as a JSON object or array: ``settings``, ``units``, ``flags``,
  ``cars``, ...): parsed and compared key by key, strings, booleans and integers exactly and floats to
  ``rtol`` of themselves (a number that moves in its last bit inside ``settings`` is held to the same
  tolerance as the same number in a dataset, not to its decimal spelling).
* HDF5 object references (dimension-scale attributes ``DIMENSION_LIST``, ``REFERENCE_LIST``): compared
  by the name of the object they point to.

Excluded, because they are legitimately run-dependent (exactly these, wherever they occur):

* attribute ``created`` (root of every result and event file): the time the file was written.
* attribute ``femref_version`` (root): the package version, bumped by releases, not by numbers.
* attribute and dataset ``wall_time_s`` (``/<model>``, ``/scores/<model>``,
  ``/events/<k>/<estimator>/<coupler>``, dataset ``/choice/wall_time_s``): measured wall-clock time.
* keys ``setup_time_s`` and ``stepping_time_s`` of the JSON attribute ``settings`` of an impact run
  (``/<model>@settings``, written by ``femref.run.runner``): measured wall-clock times of the run's set-up
  and time loop. Found by the run-to-run comparison (they differed in every impact result; nothing else did).
* attribute ``speedup`` (``/scores/<model>``): the reference's wall time over the model's — a ratio of
  two wall times.
* the SHA-256 values of attribute ``field_files`` (``/<model>/fields``): the file names are compared
  exactly, the digests not, because the field files themselves are compared dataset by dataset to
  ``rtol``; a digest would flag a last-bit change the tolerance admits.

Nothing else is excluded: no random seed or step count was found to differ from run to run (two
snapshots of the same tree compare with 0 differences, even at ``--rtol 0``). Kept although they sound like clocks: the
``training_time_s`` of a network's settings (a fact of the stored network file, not of this run) and
``/choice/predicted_cost`` (a fitted cost model, not a measurement). ``DIR/logs`` and ``DIR/snapshot.json``
are not compared (wall times in the printed tables).

Not run-dependent but checkout-dependent: the resolved case (``case_yaml``) and a network estimator's
``settings.network`` hold the absolute paths of the files a case names (records, CSV loads, network
files). In every string attribute the checkout's root (``repo`` of ``DIR/snapshot.json``) is replaced by
``<repo>`` before comparing, so that a snapshot of an older commit exported elsewhere (``git archive``)
compares with one of the working tree; everything else in those strings is compared exactly.

Exit codes: ``take`` 0 when every case ran and wrote its file, 1 otherwise, 2 when ``DIR`` is not empty or ``--only`` names no case;
``compare`` 0 when nothing differs beyond ``rtol``, 1 otherwise, with a summary of what was compared.
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse
import importlib.util
import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

REPO = Path(__file__).resolve().parents[1]
CASES = REPO / "cases"
GALLERY = REPO / "docs" / "examples"
GALLERY_FILE = "gallery.json"
#: The snapshot's own facts: the checkout's root (``repo``) and the seconds each step took.
SNAPSHOT_FILE = "snapshot.json"
#: What the checkout's root becomes in compared strings (module docstring: checkout-dependent paths).
REPO_MARK = "<repo>"
DEFAULT_RTOL = 1e-10

#: Runs beyond the case files, ``{result stem: (case stem, extra arguments of femref run)}``: the model-choice flow.
EXTRA_RUNS = {"impact_free_roll_tolerance": ("impact_free_roll", ("--tolerance", "0.002"))}
#: Attribute names never compared (module docstring: run-dependent).
EXCLUDED_ATTRIBUTES = frozenset({"created", "femref_version", "wall_time_s", "speedup"})
#: Dataset names never compared (module docstring: run-dependent).
EXCLUDED_DATASETS = frozenset({"wall_time_s"})
#: Keys inside JSON attributes never compared (``settings`` of impact runs: measured times; module docstring).
EXCLUDED_JSON_KEYS = frozenset({"setup_time_s", "stepping_time_s"})
#: JSON attribute of ``{file name: SHA-256}`` whose names are compared and digests not.
FIELD_FILES_ATTRIBUTE = "field_files"


# --- take ------------------------------------------------------------------------------------------


def take(folder: Path, only: list[str] | None = None, gallery: bool = True) -> int:
    """Run every case (or those named in ``only``) into ``folder``, then the gallery; return the exit code."""
    from click.testing import CliRunner

    from femref.cli import main

    if folder.exists() and any(folder.iterdir()):
        print(f"error: {folder} is not empty: take a snapshot into a new folder (a file left from another snapshot would be compared)",
              file=sys.stderr)
        return 2
    runs = {case.stem: (case, ()) for case in sorted(CASES.glob("*.yaml"))}
    runs |= {stem: (CASES / f"{case}.yaml", arguments) for stem, (case, arguments) in EXTRA_RUNS.items()}
    if only:
        unknown = sorted(set(only) - set(runs))
        if unknown:
            print(f"error: no case {', '.join(unknown)} (cases: {', '.join(runs)})", file=sys.stderr)
            return 2
        runs = {stem: run for stem, run in runs.items() if stem in only}
    logs = folder / "logs"
    logs.mkdir(parents=True)
    timings: dict[str, Any] = {"cases": {}, "gallery": {}}
    failed = []
    start = time.perf_counter()
    for stem, (case, arguments) in runs.items():
        began = time.perf_counter()
        result = CliRunner().invoke(main, ["run", str(case), *arguments, "-o", str(folder / f"{stem}.h5")])
        timings["cases"][stem] = round(time.perf_counter() - began, 2)
        (logs / f"{stem}.log").write_text(f"exit code {result.exit_code}\n{result.output}{result.stderr}", encoding="utf-8")
        if result.exit_code != 0:
            failed.append(stem)
        print(f"{stem:32s} exit {result.exit_code}  {timings['cases'][stem]:7.2f} s", flush=True)
    timings["cases_total_s"] = round(time.perf_counter() - start, 2)
    if gallery:
        headlines = {}
        for script in sorted(GALLERY.glob("*.py")):
            began = time.perf_counter()
            headlines[script.stem] = {key: _plain(value) for key, value in _load_gallery(script).headline.items()}
            timings["gallery"][script.stem] = round(time.perf_counter() - began, 2)
            print(f"gallery {script.stem:24s}  {timings['gallery'][script.stem]:7.2f} s", flush=True)
        (folder / GALLERY_FILE).write_text(json.dumps(headlines, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    timings["total_s"] = round(time.perf_counter() - start, 2)
    facts = {"repo": str(REPO), "seconds": timings}
    (folder / SNAPSHOT_FILE).write_text(json.dumps(facts, indent=1) + "\n", encoding="utf-8")
    print(f"took {len(runs)} runs in {timings['cases_total_s']:.1f} s, total {timings['total_s']:.1f} s into {folder}")
    for name in failed:
        print(f"error: case {name} failed (see {logs / (name + '.log')})", file=sys.stderr)
    return 1 if failed else 0


def _load_gallery(script: Path):
    """Import ``docs/examples/<name>.py`` as module ``gallery_<name>`` (tests/examples/test_gallery.py's way)."""
    spec = importlib.util.spec_from_file_location(f"gallery_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses resolve their module
    spec.loader.exec_module(module)
    return module


def _plain(value: Any) -> Any:
    """A headline value as JSON: numpy scalars to Python numbers (floats round-trip exactly through JSON)."""
    if isinstance(value, np.generic):
        return value.item()
    return value


# --- compare ---------------------------------------------------------------------------------------


@dataclass
class Comparison:
    """What was compared and every difference found (``where``: file and path; ``what``: its size or kind)."""

    rtol: float
    roots: tuple[str | None, str | None] = (None, None)
    files: int = 0
    datasets: int = 0
    attributes: int = 0
    headlines: int = 0
    excluded: int = 0
    differences: list[tuple[str, str]] = field(default_factory=list)

    def differ(self, where: str, what: str) -> None:
        self.differences.append((where, what))

    def unrooted(self, texts: tuple[str, str]) -> tuple[str, str]:
        """Each side's string with its checkout's root replaced by ``<repo>``."""
        return tuple(text.replace(root, REPO_MARK) if root else text for text, root in zip(texts, self.roots))

    def summary(self) -> str:
        lines = [f"compared {self.files} files: {self.datasets} datasets, {self.attributes} attributes, {self.headlines} gallery "
                 f"headlines ({self.excluded} run-dependent items skipped); rtol {self.rtol:g}"]
        lines += [f"  {where}: {what}" for where, what in self.differences]
        lines.append(f"{len(self.differences)} difference(s)")
        return "\n".join(lines)


def compare(a: Path, b: Path, rtol: float = DEFAULT_RTOL) -> Comparison:
    """Compare the snapshots in folders ``a`` and ``b`` (module docstring's rules)."""
    report = Comparison(rtol, roots=(_root(a), _root(b)))
    names_a, names_b = _snapshot_files(a), _snapshot_files(b)
    for name in sorted(names_a ^ names_b):
        report.differ(name, f"only in {a if name in names_a else b}")
    for name in sorted(names_a & names_b):
        report.files += 1
        if name.endswith(".h5"):
            _compare_h5(a / name, b / name, name, report)
        elif name == GALLERY_FILE:
            _compare_gallery(a / name, b / name, report)
        elif (a / name).read_text(encoding="utf-8") != (b / name).read_text(encoding="utf-8"):
            report.differ(name, "text differs")
    return report


def _root(folder: Path) -> str | None:
    """The checkout a snapshot was taken in (``repo`` of its ``snapshot.json``; None if it has none)."""
    facts = folder / SNAPSHOT_FILE
    return json.loads(facts.read_text(encoding="utf-8")).get("repo") if facts.is_file() else None


def _snapshot_files(folder: Path) -> set[str]:
    """The compared files of a snapshot folder: ``*.h5``, ``*.xdmf`` and the gallery's headlines."""
    return {p.name for p in folder.iterdir() if p.is_file() and (p.suffix in (".h5", ".xdmf") or p.name == GALLERY_FILE)}


def _compare_gallery(a: Path, b: Path, report: Comparison) -> None:
    left, right = (json.loads(p.read_text(encoding="utf-8")) for p in (a, b))
    for module in sorted(set(left) | set(right)):
        if module not in left or module not in right:
            report.differ(f"{GALLERY_FILE}:{module}", "module in one snapshot only")
            continue
        for key in sorted(set(left[module]) | set(right[module])):
            report.headlines += 1
            where = f"{GALLERY_FILE}:{module}.{key}"
            if key not in left[module] or key not in right[module]:
                report.differ(where, "headline in one snapshot only")
            else:
                _compare_json(left[module][key], right[module][key], where, report)


def _compare_h5(a: Path, b: Path, name: str, report: Comparison) -> None:
    with h5py.File(a, "r") as left, h5py.File(b, "r") as right:
        _compare_node(left, right, name, report, (_resolver(left), _resolver(right)))


def _resolver(h5: h5py.File) -> Callable[[h5py.Reference], str]:
    """Reference → the path of the object it points to (the first in visiting order of a hard-linked one).

    A map of the file's object addresses built once: ``h5[reference].name`` searches the whole file
    on every call (most of a minute over a snapshot)."""
    names = {h5py.h5o.get_info(h5.id).addr: "/"}
    h5.visititems(lambda path, obj: names.setdefault(h5py.h5o.get_info(obj.id).addr, f"/{path}") and None)

    def resolve(reference: h5py.Reference) -> str:
        if not reference:
            return "<null reference>"
        try:
            target = h5py.h5r.dereference(reference, h5.id)
        except KeyError:  # the object it pointed to was deleted
            return "<dangling reference>"
        return names.get(h5py.h5o.get_info(target).addr, "<unreachable object>")

    return resolve


def _compare_node(left: h5py.Group | h5py.Dataset, right: h5py.Group | h5py.Dataset, name: str, report: Comparison,
                  resolvers: tuple[Callable, Callable]) -> None:
    """Attributes of the object, then (a group) its members, recursively."""
    where = f"{name}:{left.name}"
    for key in sorted(set(left.attrs) | set(right.attrs)):
        if key in EXCLUDED_ATTRIBUTES:
            report.excluded += 1
            continue
        report.attributes += 1
        if key not in left.attrs or key not in right.attrs:
            report.differ(f"{where}@{key}", f"attribute only in {'A' if key in left.attrs else 'B'}")
            continue
        _compare_attribute(left.attrs[key], right.attrs[key], resolvers, key, f"{where}@{key}", report)
    if isinstance(left, h5py.Dataset):
        return
    for key in sorted(set(left) | set(right)):
        path = f"{name}:{left.name.rstrip('/')}/{key}"
        if key not in left or key not in right:
            report.differ(path, f"only in {'A' if key in left else 'B'}")
            continue
        one, other = left[key], right[key]
        if type(one) is not type(other):
            report.differ(path, f"a {type(one).__name__} in A, a {type(other).__name__} in B")
        elif isinstance(one, h5py.Dataset):
            if key in EXCLUDED_DATASETS:
                report.excluded += 1
                continue
            report.datasets += 1
            _compare_values(one[()], other[()], path, report)
            _compare_node(one, other, name, report, resolvers)
        else:
            _compare_node(one, other, name, report, resolvers)


def _compare_attribute(one: Any, other: Any, resolvers: tuple[Callable, Callable], key: str, where: str, report: Comparison) -> None:
    """An attribute: references by target name, JSON parsed, the rest as values."""
    one, other = _dereference(one, resolvers[0]), _dereference(other, resolvers[1])
    text_a, text_b = _text(one), _text(other)
    if text_a is not None and text_b is not None:
        text_a, text_b = report.unrooted((text_a, text_b))
        parsed_a, parsed_b = _json(text_a), _json(text_b)
        if parsed_a is not None and parsed_b is not None:
            if key == FIELD_FILES_ATTRIBUTE and isinstance(parsed_a, dict) and isinstance(parsed_b, dict):
                parsed_a, parsed_b = sorted(parsed_a), sorted(parsed_b)  # names only: the digests hash the compared files
            _compare_json(parsed_a, parsed_b, where, report)
        elif text_a != text_b:
            report.differ(where, _text_difference(text_a, text_b))
        return
    _compare_values(one, other, where, report)


def _dereference(value: Any, resolve: Callable[[h5py.Reference], str]) -> Any:
    """HDF5 object references (in arrays, compound rows) replaced by the name of the object they point to."""
    if isinstance(value, h5py.Reference):
        return resolve(value)
    if isinstance(value, np.ndarray) and value.dtype.kind == "O":
        return [_dereference(item, resolve) for item in value.ravel()]
    if isinstance(value, np.ndarray) and value.dtype.names:  # compound rows, e.g. REFERENCE_LIST's (dataset, dimension)
        return [_dereference(item, resolve) for item in value.tolist()]
    if isinstance(value, (tuple, list)):
        return [_dereference(item, resolve) for item in value]
    return value


def _text(value: Any) -> str | None:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, str):
        return value
    return None


def _json(text: str) -> Any:
    """``text`` parsed, when it is a JSON object or array (a plain string or number stays text)."""
    if not text.lstrip().startswith(("{", "[")):
        return None
    try:
        return json.loads(text)
    except ValueError:
        return None


def _text_difference(a: str, b: str) -> str:
    """Where two strings part: the line, and a little of each side from there."""
    at = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    line = a.count("\n", 0, at) + 1
    start = max(0, at - 20)
    return f"text differs from line {line}: {a[start:at + 40]!r} / {b[start:at + 40]!r}"


def _short(text: str, width: int = 80) -> str:
    return text if len(text) <= width else text[: width - 3] + "..."


def _compare_json(one: Any, other: Any, where: str, report: Comparison) -> None:
    """Parsed JSON (or gallery headlines): containers key by key, floats to rtol of themselves, the rest exactly."""
    if isinstance(one, dict) and isinstance(other, dict):
        for key in sorted(set(one) | set(other), key=str):
            if key in EXCLUDED_JSON_KEYS:
                report.excluded += 1
            elif key not in one or key not in other:
                report.differ(f"{where}.{key}", f"key only in {'A' if key in one else 'B'}")
            else:
                _compare_json(one[key], other[key], f"{where}.{key}", report)
    elif isinstance(one, list) and isinstance(other, list):
        if len(one) != len(other):
            report.differ(where, f"length {len(one)} / {len(other)}")
        else:
            for index, (x, y) in enumerate(zip(one, other)):
                _compare_json(x, y, f"{where}[{index}]", report)
    elif is_number(one) and is_number(other) and (isinstance(one, float) or isinstance(other, float)):
        _compare_values(np.float64(one), np.float64(other), where, report)
    elif type(one) is not type(other) or one != other:
        report.differ(where, f"{_short(repr(one))} / {_short(repr(other))}")


def is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _compare_values(one: Any, other: Any, where: str, report: Comparison) -> None:
    """Two values read from HDF5 (arrays or scalars): numbers by the relative rule, anything else exactly."""
    a, b = np.asarray(one), np.asarray(other)
    if a.shape != b.shape:
        report.differ(where, f"shape {a.shape} / {b.shape}")
        return
    if a.dtype.kind in "biufc" and b.dtype.kind in "biufc":
        if a.dtype != b.dtype:
            report.differ(where, f"dtype {a.dtype} / {b.dtype}")
            return
        message = _numeric_difference(a, b, report.rtol)
        if message:
            report.differ(where, message)
    elif a.dtype.kind in "biufc" or b.dtype.kind in "biufc":
        report.differ(where, f"dtype {a.dtype} / {b.dtype}")
    elif _plain_list(a) != _plain_list(b):
        report.differ(where, f"{_short(repr(_plain_list(a)))} / {_short(repr(_plain_list(b)))}")


def _plain_list(array: np.ndarray) -> Any:
    """A non-numeric array as nested Python values, bytes decoded (h5py gives strings as bytes or str)."""
    items = array.tolist()

    def plain(item: Any) -> Any:
        if isinstance(item, bytes):
            return item.decode("utf-8", "replace")
        if isinstance(item, (list, tuple)):
            return [plain(x) for x in item]
        return item

    return plain(items)


def _numeric_difference(a: np.ndarray, b: np.ndarray, rtol: float) -> str | None:
    """None when ``b`` equals ``a`` to ``rtol`` of the arrays' max |value|; else the size of the difference."""
    if a.dtype.kind in "biu":
        count = int(np.count_nonzero(a != b))
        return f"{count} of {a.size} integer entries differ" if count else None
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    inf_a, inf_b = np.isinf(a), np.isinf(b)
    if not np.array_equal(nan_a, nan_b):
        return f"NaN at different places ({int(np.count_nonzero(nan_a != nan_b))} entries)"
    if not np.array_equal(inf_a, inf_b) or not np.array_equal(a[inf_a], b[inf_b]):
        return "infinities at different places or of different sign"
    finite = ~(nan_a | inf_a)
    if not np.any(finite):
        return None
    x, y = a[finite], b[finite]
    deviation = np.abs(x - y)
    largest = float(np.max(deviation))
    if largest == 0.0:
        return None
    scale = max(float(np.max(np.abs(x))), float(np.max(np.abs(y))))
    relative = largest / scale if scale > 0.0 else math.inf
    if relative <= rtol:
        return None
    count = int(np.count_nonzero(deviation > rtol * scale))
    return f"max |A−B| {largest:.3e} = {relative:.3e} of max |value| {scale:.3e}; {count} of {a.size} entries beyond rtol"


# --- command line ----------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    take_parser = commands.add_parser("take", help="run every case and the gallery into DIR")
    take_parser.add_argument("folder", metavar="DIR", type=Path)
    take_parser.add_argument("--only", nargs="+", metavar="NAME", help="run only these cases (file stems)")
    take_parser.add_argument("--no-gallery", action="store_true", help="skip the gallery's headlines")
    compare_parser = commands.add_parser("compare", help="compare two snapshots; exit 1 on any difference")
    compare_parser.add_argument("a", metavar="A", type=Path)
    compare_parser.add_argument("b", metavar="B", type=Path)
    compare_parser.add_argument("--rtol", type=float, default=DEFAULT_RTOL, help="relative to each dataset's max |value| (default 1e-10)")
    args = parser.parse_args(argv)
    if args.command == "take":
        return take(args.folder, args.only, gallery=not args.no_gallery)
    for folder in (args.a, args.b):
        if not folder.is_dir():
            print(f"error: {folder} is not a snapshot folder", file=sys.stderr)
            return 1
    report = compare(args.a, args.b, args.rtol)
    print(report.summary())
    return 1 if report.differences else 0


if __name__ == "__main__":
    sys.exit(main())
