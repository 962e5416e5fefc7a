"""Who writes a temporary, beyond its pid: the writer's identity and whether it still runs.

A pid alone names a process only inside its PID namespace: two containers, or two hosts sharing a
folder over NFS, have processes of the same pid, and a pid that ended here may be a live run there.
So every temporary :func:`femref.core.publishing.create_temporary` makes has, beside it and made
*before* it, a small sidecar ``<temporary>.writer`` holding its :class:`Writer` — the host name, the
kernel's boot id (the machine and its boot: every container on a host shares it), the inode of the
writer's PID namespace (``/proc/self/ns/pid``), its pid and its start time (clock ticks after boot,
field 22 of ``/proc/<pid>/stat``: a pid reused by a later process has another).

:func:`writer_running` then answers for a recorded writer: ``True`` while that very process runs (the
same host, boot and PID namespace as the asking process, and a process of that pid started at that
time), ``False`` once it ended, ``None`` when the asking process cannot see it (another host, boot or
PID namespace) — such a temporary is kept and named, never removed. Without ``/proc`` (not Linux) the
pid alone decides, on the same host. The sidecar is a plain file: no lock to keep.
"""

from __future__ import annotations

import json
import os
import socket
from dataclasses import asdict, dataclass
from pathlib import Path

#: Suffix of a temporary's sidecar: ``<temporary>.writer`` holds the :class:`Writer` (JSON).
SIDECAR_SUFFIX = ".writer"
_PROC = Path("/proc")


@dataclass(frozen=True)
class Writer:
    """A process writing a temporary: ``host`` name, kernel ``boot`` id, PID ``namespace`` inode, ``pid`` and
    ``start`` time (clock ticks after boot); ``boot``, ``namespace`` and ``start`` are empty/0 without ``/proc``."""

    host: str
    boot: str
    namespace: int
    pid: int
    start: int

    def describe(self) -> str:
        """How messages name the writer: ``femref process 123 on host vm (PID namespace 4026531836)``."""
        return f"femref process {self.pid} on host {self.host} (PID namespace {self.namespace or 'unknown'})"


def this_writer() -> Writer:
    """The :class:`Writer` of the calling process (read afresh: a forked worker is another process)."""
    pid = os.getpid()
    return Writer(socket.gethostname(), _boot_id(), _namespace(), pid, start_time(pid) or 0)


def writer_running(writer: Writer) -> bool | None:
    """Whether ``writer`` still runs: True (that process, same pid and start time), False (ended: no process of that
    pid, or one started at another time), None (another machine, boot or PID namespace: unknown). Without ``/proc``
    the pid alone decides, on the same host."""
    here = this_writer()
    if (writer.host, writer.boot, writer.namespace) != (here.host, here.boot, here.namespace):
        return None
    if not here.start:  # no /proc (not Linux): the pid alone, on this host
        return process_alive(writer.pid)
    return start_time(writer.pid) == writer.start


def process_alive(pid: int) -> bool:
    """A process of ``pid`` exists in this PID namespace (``kill(pid, 0)``; another user's counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def start_time(pid: int) -> int | None:
    """Start time of process ``pid`` in clock ticks after boot (``/proc/<pid>/stat`` field 22), None if there is none."""
    try:
        stat = (_PROC / str(pid) / "stat").read_text()
    except OSError:
        return None
    fields = stat[stat.rfind(")") + 2:].split()  # after the command name, which may hold spaces: field 3 onwards
    return int(fields[22 - 3])


def write_sidecar(temporary: Path) -> Path:
    """Create (exclusively: ``FileExistsError`` if taken) ``<temporary>.writer`` holding this process's :class:`Writer`."""
    sidecar = sidecar_of(temporary)
    descriptor = os.open(sidecar, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    try:
        with os.fdopen(descriptor, "w") as stream:
            json.dump(asdict(this_writer()), stream)
    except BaseException:
        sidecar.unlink(missing_ok=True)
        raise
    return sidecar


def read_sidecar(temporary: Path) -> Writer | None:
    """The :class:`Writer` recorded beside ``temporary``, None if there is no sidecar or it cannot be read (being
    written, or damaged)."""
    try:
        recorded = json.loads(sidecar_of(temporary).read_text())
        return Writer(str(recorded["host"]), str(recorded["boot"]), int(recorded["namespace"]), int(recorded["pid"]), int(recorded["start"]))
    except (OSError, ValueError, TypeError, KeyError):
        return None


def sidecar_of(temporary: Path) -> Path:
    """``<temporary>.writer``."""
    return temporary.with_name(temporary.name + SIDECAR_SUFFIX)


def _boot_id() -> str:
    try:
        return (_PROC / "sys" / "kernel" / "random" / "boot_id").read_text().strip()
    except OSError:
        return ""


def _namespace() -> int:
    try:
        return os.stat(_PROC / "self" / "ns" / "pid").st_ino
    except OSError:
        return 0


__all__ = ["SIDECAR_SUFFIX", "Writer", "process_alive", "read_sidecar", "sidecar_of", "start_time", "this_writer", "write_sidecar",
           "writer_running"]
