"""Where femref writes files: under a temporary name, published by a rename, never half-written; the leftovers of
killed and older runs; the rule every writer applies to its output path before any work.

Temporaries are named ``.<final name>.femref-<pid>[.<part>].tmp`` beside the final file (:func:`temporary_path`),
each with a sidecar ``<temporary>.writer`` made before it that identifies its writer beyond the pid — machine
(boot id), PID namespace, pid and start time (:mod:`femref.core.writers`): a write that fails removes its
temporary, a killed one leaves it, and the next write of the same final name removes the leftovers whose
writer ended — never a live run's, nor one of a writer it cannot see (another container, another host
sharing the folder), which it keeps and names (:func:`remove_leftovers`, :func:`unseen_temporaries`). A
pid-named temporary without a sidecar (femref before writer sidecars) is judged by its pid alone.

An OS error while writing (a full disk, a quota, an I/O error) ends the write with that ``OSError``, noted
with what it left (:func:`note_output`): the temporary removed and the previous file unchanged
(:func:`atomic_path`). HDF5 files are written through :func:`femref.core.hdf5_writing.hdf5_writer`, which keeps the HDF5
library from ever seeing a failed write (after one, HDF5 2.0 leaves its caches inconsistent: it printed a
traceback per object and then crashed with SIGSEGV on a full disk) and raises the recorded error once the
file is closed.

Older femref versions (before pid-named temporaries) named theirs at random: the result file
``.<final name>.<8 random characters>.tmp`` (``tempfile.mkstemp``) and a folder ``tmp<8 random characters>``
(``tempfile.mkdtemp``) of the field files ``<result stem>_<model>_fields.xdmf|.h5``; :func:`legacy_leftovers`
recognises them by name *and* content, and removes only what is certainly unused.

The output path (before any work): :func:`check_output_path` is the rule every command and
:func:`femref.api.run_case` apply to where they write, raising :class:`OutputPathError` (a ``ValueError``;
the command line's exit 2); :func:`clean_leftovers` then removes the output's leftovers of killed and older runs.
"""

from __future__ import annotations

import contextlib
import glob
import os
import re
import shutil
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from femref.core.writers import SIDECAR_SUFFIX, process_alive, read_sidecar, sidecar_of, write_sidecar, writer_running

_TEMPORARY = re.compile(r"^\.(?P<final>.+)\.femref-(?P<pid>\d+)(?:-\d+)?(?:\.(?P<part>[a-z]+))?\.tmp$")


def temporary_path(path: str | Path, part: str = "") -> Path:
    """``.<name>.femref-<pid>[.<part>].tmp`` beside ``path``: the name a later run recognises as a leftover."""
    path = Path(path)
    return path.with_name(f".{path.name}.femref-{os.getpid()}" + (f".{part}" if part else "") + ".tmp")


def create_temporary(path: Path, part: str = "", folder: bool = False) -> Path:
    """Create (exclusively) the temporary file or folder of ``path``, its writer sidecar first
    (:mod:`femref.core.writers`); ``-<n>`` after the pid if taken."""
    base = temporary_path(path, part)
    for n in range(1, 1000):
        candidate = base if n == 1 else base.with_name(base.name.replace(f"-{os.getpid()}", f"-{os.getpid()}-{n}", 1))
        try:
            sidecar = write_sidecar(candidate)
        except FileExistsError:
            continue
        try:
            if folder:
                candidate.mkdir()
            else:
                os.close(os.open(candidate, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
        except FileExistsError:  # a temporary without a sidecar (an older femref's): not ours to reuse
            sidecar.unlink(missing_ok=True)
            continue
        except BaseException:
            sidecar.unlink(missing_ok=True)
            raise
        return candidate
    raise FileExistsError(f"{base}: no free temporary name")


def discard_temporary(temporary: Path) -> str:
    """Remove this process's ``temporary`` (file or folder), if still there — published ones are not — and its writer
    sidecar; ``""``, or why the temporary could not be removed (it is then left, with its sidecar)."""
    try:
        if temporary.is_dir() and not temporary.is_symlink():
            shutil.rmtree(temporary)
        else:
            temporary.unlink(missing_ok=True)
    except OSError as error:
        return error.strerror or str(error)
    sidecar_of(temporary).unlink(missing_ok=True)
    return ""


def _temporaries(path: Path) -> list[Path]:
    """The pid-named temporaries of ``path``'s final name in its folder (files or folders)."""
    if not path.parent.is_dir():
        return []
    found = []
    for entry in path.parent.iterdir():
        match = _TEMPORARY.match(entry.name)
        if match and match["final"] == path.name:
            found.append(entry)
    return sorted(found)


def _writer_running(temporary: Path) -> bool | None:
    """Whether the writer of ``temporary`` still runs (:func:`femref.core.writers.writer_running`), None when this
    process cannot tell (its sidecar names a writer out of sight, or cannot be read yet). Without a sidecar (an
    older femref's temporary): whether a process of the pid in its name lives here."""
    if sidecar_of(temporary).exists():
        writer = read_sidecar(temporary)
        return None if writer is None else writer_running(writer)
    pid = int(_TEMPORARY.match(temporary.name)["pid"])
    return pid == os.getpid() or process_alive(pid)


def leftovers(path: str | Path) -> list[Path]:
    """Temporaries of ``path``'s final name (files or folders) whose writer ended (module docstring)."""
    return [entry for entry in _temporaries(Path(path)) if _writer_running(entry) is False]


def unseen_temporaries(path: str | Path) -> list[tuple[Path, str]]:
    """Temporaries of ``path``'s final name whose writer this process cannot see, each with who wrote it (a
    process of another container or host, :meth:`femref.core.writers.Writer.describe`): kept, never removed."""
    unseen = []
    for entry in _temporaries(Path(path)):
        if _writer_running(entry) is None:
            writer = read_sidecar(entry)
            unseen.append((entry, writer.describe() if writer else "a femref process whose sidecar cannot be read yet"))
    return unseen


def remove_leftovers(path: str | Path) -> list[Path]:
    """Remove :func:`leftovers` of ``path`` (a killed run's temporaries) and their sidecars, and the sidecars whose
    writer ended without a temporary; return the temporaries removed."""
    path = Path(path)
    removed = []
    for entry in leftovers(path):
        _remove(entry)
        sidecar_of(entry).unlink(missing_ok=True)
        removed.append(entry)
    if path.parent.is_dir():
        for sidecar in path.parent.glob(f".{glob.escape(path.name)}.femref-*{SIDECAR_SUFFIX}"):
            temporary = sidecar.with_name(sidecar.name.removesuffix(SIDECAR_SUFFIX))
            writer = read_sidecar(temporary)
            if not temporary.exists() and writer is not None and writer_running(writer) is False:
                sidecar.unlink(missing_ok=True)
    return removed


#: Seconds an older femref's temporary must be unchanged before :func:`remove_legacy_leftovers` removes it.
LEGACY_QUIET_SECONDS = 600.0
#: ``tempfile``'s random names: 8 characters of this alphabet.
_RANDOM = "[a-z0-9_]{8}"
_LEGACY_FOLDER = re.compile(rf"^tmp{_RANDOM}$")
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_XDMF_STARTS = (b"<Xdmf", b"<?xml")


def _remove(entry: Path) -> None:
    """Remove the file or folder ``entry`` (a link itself, never what it points to), ignoring errors of a folder's."""
    if entry.is_dir() and not entry.is_symlink():
        shutil.rmtree(entry, ignore_errors=True)
    else:
        entry.unlink(missing_ok=True)


@dataclass
class LegacyLeftovers:
    """An older femref's temporaries of one final name: those safe to remove, and those kept with the reason."""

    removable: list[Path] = field(default_factory=list)
    kept: list[tuple[Path, str]] = field(default_factory=list)


def legacy_leftovers(path: str | Path, now: float | None = None) -> LegacyLeftovers:
    """An older femref's temporaries of ``path`` (module docstring): ``tmp<random>`` folders holding nothing but field
    files of this result and ``.<name>.<random>.tmp`` files (HDF5 and XDMF by their first bytes), split into the
    removable ones (owned by this user, unchanged for :data:`LEGACY_QUIET_SECONDS` before ``now``, used by no
    process, ``/proc``) and the kept ones (why); without ``/proc`` nothing is removable."""
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


def remove_legacy_leftovers(path: str | Path) -> LegacyLeftovers:
    """Remove the removable :func:`legacy_leftovers` of ``path``; return them (removed) and the kept ones."""
    found = legacy_leftovers(path)
    for entry in found.removable:
        _remove(entry)  # a folder was checked: regular files only, no links to follow
    return found


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


# --- the output path, checked before any work: the rule femref's commands and femref.api share --------------------


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
    an older femref's (``legacy``) — those it kept with the reason (``kept``: an older femref's, not certainly
    unused) and those it kept with their writer (``unseen``: a writer of another container or host)."""

    killed: list[Path] = field(default_factory=list)
    legacy: list[Path] = field(default_factory=list)
    kept: list[tuple[Path, str]] = field(default_factory=list)
    unseen: list[tuple[Path, str]] = field(default_factory=list)


def clean_leftovers(path: str | Path) -> LeftoverCleanup:
    """Remove the temporaries of ``path`` that no running process writes (:func:`remove_leftovers`,
    :func:`remove_legacy_leftovers`); return what was removed and what was kept (:class:`LeftoverCleanup`)."""
    killed = remove_leftovers(path)
    legacy = remove_legacy_leftovers(path)
    return LeftoverCleanup(killed, legacy.removable, legacy.kept, unseen_temporaries(path))


def note_output(error: OSError, path: Path, temporary: Path | None, leftover: str = "") -> OSError:
    """``error`` (unchanged: its type and message stay the OS's) with a note of what it left of ``path``: nothing
    written there (the previous file unchanged), and the temporary removed — or, if removing it failed too
    (``leftover``: why), its name to remove by hand. The command line prints the note on the error's line."""
    before = f"the previous {path.name} is unchanged" if path.exists() else "there was no file"
    if temporary is None:
        after = ""
    elif leftover:
        after = f"; its temporary {temporary} is left ({leftover}): remove it by hand"
    else:
        after = f"; its temporary {temporary.name} was removed"
    error.add_note(f"nothing was written to {path} ({before}){after}")
    return error


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write; renamed to ``path`` when the block ends without error.

    On any error (or interrupt) the temporary file is removed, so nothing is ever left
    under the final name half-written (docs/design.md §4); a kill leaves the temporary
    (:func:`temporary_path`), which the next write of ``path`` removes. An ``OSError`` (a full
    disk, a quota, an I/O error, in the block or in the rename) comes out unchanged with a note of what it left
    (:func:`note_output`). The file gets the permissions of a newly created file (umask). Creates the folder.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_leftovers(path)
        tmp = create_temporary(path)
    except OSError as error:
        raise note_output(error, path, None)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except OSError as error:
        raise note_output(error, path, tmp, discard_temporary(tmp))
    except BaseException:
        discard_temporary(tmp)
        raise
    discard_temporary(tmp)  # published: its sidecar


__all__ = ["HDF5_SIGNATURE", "LEGACY_QUIET_SECONDS", "LeftoverCleanup", "LegacyLeftovers", "OutputPathError", "atomic_path",
           "check_output_path", "clean_leftovers", "create_temporary", "discard_temporary", "legacy_leftovers", "leftovers", "note_output",
           "output_problem", "remove_leftovers", "remove_legacy_leftovers", "same_file", "temporary_path", "unseen_temporaries"]
