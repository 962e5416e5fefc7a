"""Faults end cleanly (issue 33, item 4).

* an OS error while writing — a full disk (a real, small tmpfs), or EIO, EDQUOT, EACCES, EROFS (the
  failing call replaced) — ends ``femref run`` with exit 1 and one ``error:`` line naming the output and
  the reason; the previous file is unchanged and no temporary is left (or the one left is named);
* temporaries name their writer beyond the pid (:mod:`femref.core.writers`): a live writer in another PID
  namespace whose pid has ended here — a real one, made with ``unshare --pid``, and faked identities — is
  never taken for a killed run, in either direction;
* SIGINT and SIGTERM stop a long fem run (the compiled loop) within 2 s, exit 130 and 143, nothing written.
"""

from __future__ import annotations

import errno
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

import femref.core.hdf5_writing
import femref.core.publishing
from femref.cli import main
from femref.core.publishing import create_temporary, leftovers, remove_leftovers, unseen_temporaries
from femref.core.writers import read_sidecar, sidecar_of, start_time, this_writer, writer_running

from support.measured import yard_case_with_inverse_estimators
from support.paths import REPO

PREVIOUS = b"the previous result, kept byte for byte"


def impact_case(folder: Path) -> Path:
    """Two cars, fem (8 elements) and rigid, 0.1 s: a result of about 80 kB, written in well under a second."""
    from femref.case.defaults import default_scene_data

    data = default_scene_data()
    data.pop("measurement")
    data.pop("estimators")
    data["fem"]["elements"] = 8
    data["models"] = ["fem", "rigid"]
    data["time"] = {"end": 0.1}
    path = folder / "impact.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def temporaries_of(output: Path) -> list[str]:
    """Names beside ``output`` that are its temporaries or their sidecars."""
    return sorted(p.name for p in output.parent.iterdir() if p.name.startswith(f".{output.name}.femref-"))


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("error:")]


@pytest.fixture
def full_disk(tmp_path: Path):
    """A 64 kB tmpfs at ``tmp_path/disk`` holding the previous result ``out.h5``; unmounted afterwards."""
    disk = tmp_path / "disk"
    disk.mkdir()
    if shutil.which("mount") is None:
        pytest.skip("no mount command here")
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(disk)], capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"mounting a tmpfs needs root (CAP_SYS_ADMIN): {mounted.stderr.strip()}")
    try:
        (disk / "out.h5").write_bytes(PREVIOUS)
        yield disk
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=True)


def run_femref(*arguments: str, **env: str) -> subprocess.CompletedProcess:
    """``femref <arguments>`` in a subprocess (a crash takes only that process with it)."""
    return subprocess.run([sys.executable, "-c", "from femref.cli import main; main()", *arguments], capture_output=True, text=True,
                          timeout=300, env={**os.environ, "OPENBLAS_NUM_THREADS": "1", **env})


def assert_clean_failure(exit_code: int, stderr: str, output: Path, reason: str) -> None:
    """Exit 1, one ``error:`` line naming ``output`` and ``reason``, no traceback; the previous file intact, no temporary."""
    assert exit_code == 1, (exit_code, stderr[-3000:])
    lines = error_lines(stderr)
    assert len(lines) == 1 and "Traceback" not in stderr, stderr[-3000:]
    assert lines[0].startswith(f"error: {output.parent}/.out.h5.femref-"), lines  # the file the OS refused: the temporary
    assert f": {reason}; nothing was written to {output} (the previous out.h5 is unchanged); its temporary .out.h5.femref-" in lines[0], lines
    assert lines[0].endswith(".tmp was removed"), lines
    assert output.read_bytes() == PREVIOUS
    assert temporaries_of(output) == []


# --- OS errors while writing -----------------------------------------------------------------------------------------


def test_a_full_disk_ends_an_impact_run_in_one_error_line(full_disk, tmp_path):
    """The result does not fit on a 64 kB tmpfs: before, HDF5 printed a traceback per object it released and the
    process died of SIGSEGV in H5Fclose, its temporary left; now one line, exit 1, the previous file intact."""
    output = full_disk / "out.h5"
    done = run_femref("run", str(impact_case(tmp_path)), "-o", str(output))
    assert_clean_failure(done.returncode, done.stderr, output, "No space left on device (ENOSPC)")


def test_a_full_disk_ends_a_measured_run_in_one_error_line(full_disk, tmp_path):
    """The yard case's event file on a 64 kB tmpfs: before, SIGSEGV after a traceback per released HDF5 object."""
    output = full_disk / "out.h5"
    done = run_femref("run", str(yard_case_with_inverse_estimators(tmp_path)), "-o", str(output))
    assert_clean_failure(done.returncode, done.stderr, output, "No space left on device (ENOSPC)")


class FailingFile:
    """A raw file whose writes fail with ``code`` once ``budget`` bytes are written (a disk filling up, a quota, a
    dying device), as the file :func:`femref.core.hdf5_writing.hdf5_writer` writes through."""

    def __init__(self, file, code: int, budget: int) -> None:
        self.file, self.code, self.budget = file, code, budget

    def write(self, data) -> int:
        if self.budget <= 0:
            raise OSError(self.code, os.strerror(self.code))
        done = self.file.write(memoryview(data)[: self.budget])  # a part first, as a disk filling up does
        self.budget -= done
        return done

    def __getattr__(self, name: str):
        return getattr(self.file, name)


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EDQUOT, errno.EIO])
def test_a_write_that_fails_ends_the_run_in_one_error_line(code, tmp_path, monkeypatch):
    """The result file's writes fail after 20 kB with ENOSPC, EDQUOT or EIO: exit 1, one line with the reason and
    its errno name, the previous file intact, no temporary."""
    real_init = femref.core.hdf5_writing._RecordingStream.__init__

    def failing_init(self, path, truncate):
        real_init(self, path, truncate)
        self.file = FailingFile(self.file, code, 20_000)

    monkeypatch.setattr(femref.core.hdf5_writing._RecordingStream, "__init__", failing_init)
    output = tmp_path / "out.h5"
    output.write_bytes(PREVIOUS)
    result = CliRunner().invoke(main, ["run", str(impact_case(tmp_path)), "-o", str(output)])
    assert_clean_failure(result.exit_code, result.stderr, output, f"{os.strerror(code)} ({errno.errorcode[code]})")


@pytest.mark.parametrize("code", [errno.EACCES, errno.EROFS])
def test_a_rename_that_fails_ends_the_run_in_one_error_line(code, tmp_path, monkeypatch):
    """Publishing (the rename) refused with EACCES or EROFS: exit 1, one line naming both paths
    (``<temporary> -> <output>: …``), the previous file intact, no temporary."""
    def refused(source, target):
        raise OSError(code, os.strerror(code), str(source), None, str(target))

    monkeypatch.setattr(femref.core.publishing.os, "replace", refused)
    output = tmp_path / "out.h5"
    output.write_bytes(PREVIOUS)
    result = CliRunner().invoke(main, ["run", str(impact_case(tmp_path)), "-o", str(output)])
    assert_clean_failure(result.exit_code, result.stderr, output, f"{os.strerror(code)} ({errno.errorcode[code]})")
    assert f".tmp -> {output}: " in result.stderr


def test_a_temporary_that_cannot_be_removed_is_named(tmp_path, monkeypatch):
    """The write fails with EIO and removing the temporary fails too (EROFS): the line names the temporary left."""
    real_init = femref.core.hdf5_writing._RecordingStream.__init__

    def failing_init(self, path, truncate):
        real_init(self, path, truncate)
        self.file = FailingFile(self.file, errno.EIO, 0)

    monkeypatch.setattr(femref.core.hdf5_writing._RecordingStream, "__init__", failing_init)
    monkeypatch.setattr(femref.core.publishing, "discard_temporary", lambda temporary: os.strerror(errno.EROFS))
    output = tmp_path / "out.h5"
    output.write_bytes(PREVIOUS)
    result = CliRunner().invoke(main, ["run", str(impact_case(tmp_path)), "-o", str(output)])
    assert result.exit_code == 1
    [line] = error_lines(result.stderr)
    [temporary] = [output.parent / name for name in temporaries_of(output) if name.endswith(".tmp")]
    assert line.endswith(f"its temporary {temporary} is left (Read-only file system): remove it by hand"), line
    assert output.read_bytes() == PREVIOUS


def test_an_os_error_during_the_run_is_one_error_line(tmp_path, monkeypatch):
    """An OS error outside publishing (a record read back with EIO, here raised by the run itself): exit 1, one line
    ``error: <path>: <reason> (<errno name>)``, nothing written."""
    import femref.run

    def unreadable(*args, **kwargs):
        raise OSError(errno.EIO, os.strerror(errno.EIO), "/records/hammer.csv")

    monkeypatch.setattr(femref.run, "run_scene", unreadable)
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(impact_case(tmp_path)), "-o", str(output)])
    assert result.exit_code == 1 and error_lines(result.stderr) == ["error: /records/hammer.csv: Input/output error (EIO)"], result.output
    assert not output.exists() and temporaries_of(output) == []


# --- temporaries name their writer beyond the pid -----------------------------------------------------------------------


def dead_pid() -> int:
    """The pid of a process that has ended (and been reaped)."""
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


def fake_writer_temporary(output: Path, **identity) -> Path:
    """A temporary of ``output`` made by this process, its sidecar then rewritten with ``identity`` in place of ours."""
    temporary = create_temporary(output)
    sidecar_of(temporary).write_text(json.dumps({**asdict(this_writer()), **identity}))
    return temporary


def test_a_writer_is_its_machine_namespace_pid_and_start_time(tmp_path):
    """The sidecar records this process (host, boot id, PID-namespace inode, pid, start time), and a process is
    running exactly while a process of its pid started at its start time lives in the same namespace."""
    me = this_writer()
    assert me.pid == os.getpid() and me.namespace == os.stat("/proc/self/ns/pid").st_ino and me.start == start_time(os.getpid()) > 0
    temporary = create_temporary(tmp_path / "out.h5")
    assert read_sidecar(temporary) == me and writer_running(me) is True
    assert writer_running(replace(me, pid=dead_pid())) is False
    assert writer_running(replace(me, start=me.start + 1)) is False  # the pid reused by a later process
    assert writer_running(replace(me, namespace=me.namespace + 1)) is None  # another container: not seen
    assert writer_running(replace(me, boot="another machine")) is None


def test_without_proc_a_writer_is_its_host_and_pid(monkeypatch):
    """Where ``/proc`` cannot tell start times (not Linux), a writer of this host runs while a process of its pid does."""
    import femref.core.writers

    monkeypatch.setattr(femref.core.writers, "start_time", lambda pid: None)
    me = this_writer()
    assert me.start == 0 and writer_running(me) is True and writer_running(replace(me, pid=dead_pid())) is False
    assert writer_running(replace(me, host="peer")) is None


def test_faked_writers_of_other_namespaces_are_kept_and_named(tmp_path):
    """Temporaries whose sidecars name a pid that has ended here: of this namespace, removed (a killed run's); of
    another PID namespace or machine, kept and named, even though their pid is dead here."""
    output = tmp_path / "out.h5"
    gone = dead_pid()
    killed = fake_writer_temporary(output, pid=gone)
    elsewhere = fake_writer_temporary(output, pid=gone, namespace=4026531000)
    other_host = fake_writer_temporary(output, pid=gone, host="peer", boot="4b1d")
    assert leftovers(output) == [killed]
    assert [entry for entry, _ in unseen_temporaries(output)] == sorted([elsewhere, other_host])
    assert remove_leftovers(output) == [killed]
    assert not killed.exists() and not sidecar_of(killed).exists() and elsewhere.exists() and other_host.exists()
    result = CliRunner().invoke(main, ["run", str(impact_case(tmp_path)), "-o", str(output)])
    assert result.exit_code == 0, result.output
    assert f"note: kept {elsewhere}: a temporary of out.h5 written by femref process {gone} on host" in result.stderr
    assert f"note: kept {other_host}: a temporary of out.h5 written by femref process {gone} on host peer" in result.stderr


#: A writer of ``out.h5`` in a folder: holds its temporary until told, cleaning as ``femref run`` does meanwhile.
WRITER = """
import json, os, sys, time
from pathlib import Path
from femref.core.publishing import atomic_path, clean_leftovers
folder, name, other = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
def wait(flag):
    while not (folder / flag).exists():
        time.sleep(0.01)
def flag(name, text):  # whole when it appears: the test reads a flag as soon as it exists
    part = folder / (name + ".part")
    part.write_text(text)
    part.replace(folder / name)
with atomic_path(folder / "out.h5") as temporary:
    temporary.write_text(name)
    flag(f"{name}.ready", json.dumps([temporary.name, os.getpid()]))
    wait(f"{other}.ready")
    cleanup = clean_leftovers(folder / "out.h5")
    flag(f"{name}.cleaned", json.dumps({"killed": [p.name for p in cleanup.killed], "unseen": [p.name for p, _ in cleanup.unseen]}))
    wait(f"{name}.go")
"""


def test_writers_in_two_pid_namespaces_keep_each_others_temporaries(tmp_path):
    """Writer A runs in a new PID namespace (``unshare --pid``) with the pid of a process that ended out here; writer
    B runs here, its pid unknown in A's namespace. Each cleans the output's leftovers while the other's temporary is
    live: before, each took the other's for a killed run's and removed it (B removed A's: A then failed to publish);
    now each keeps the other's and names it, both publish, and nothing is left."""
    if shutil.which("unshare") is None or subprocess.run(["unshare", "--pid", "--fork", "true"], capture_output=True).returncode:
        pytest.skip("unshare --pid is not available here (needs root or user namespaces)")
    collide = dead_pid()  # A gets this pid in its namespace: a pid no process has out here
    command = [sys.executable, "-c", WRITER, str(tmp_path)]
    # the shell is pid 1 of the new namespace; the next process it starts gets the pid after ns_last_pid
    inner = f"echo {collide - 1} > /proc/sys/kernel/ns_last_pid; {shlex.join([*command, 'A', 'B'])}; status=$?; exit $status"
    writer_a = subprocess.Popen(["unshare", "--pid", "--fork", "--kill-child", "--mount-proc", "sh", "-c", inner], cwd=REPO,
                                stderr=subprocess.PIPE, text=True)
    writer_b = subprocess.Popen([*command, "B", "A"], cwd=REPO, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60.0
        while not all((tmp_path / f"{name}.cleaned").exists() for name in "AB"):
            assert writer_a.poll() is None and writer_b.poll() is None, (writer_a.stderr.read() if writer_a.poll() is not None else writer_b.stderr.read())
            assert time.monotonic() < deadline
            time.sleep(0.02)
        (temporary_a, pid_a), (temporary_b, _) = (json.loads((tmp_path / f"{name}.ready").read_text()) for name in "AB")
        assert pid_a == collide and not Path(f"/proc/{collide}").exists()  # the collision: A's pid is dead out here
        assert json.loads((tmp_path / "B.cleaned").read_text()) == {"killed": [], "unseen": [temporary_a]}
        assert json.loads((tmp_path / "A.cleaned").read_text()) == {"killed": [], "unseen": [temporary_b]}
        (tmp_path / "B.go").touch()
        assert writer_b.wait(timeout=30) == 0, writer_b.stderr.read()
        assert (tmp_path / "out.h5").read_text() == "B" and (tmp_path / temporary_a).read_text() == "A"
        (tmp_path / "A.go").touch()
        assert writer_a.wait(timeout=30) == 0, writer_a.stderr.read()
    finally:
        for writer in (writer_a, writer_b):
            if writer.poll() is None:
                writer.kill()
                writer.wait()
    assert (tmp_path / "out.h5").read_text() == "A" and temporaries_of(tmp_path / "out.h5") == []


# --- SIGINT and SIGTERM ---------------------------------------------------------------------------------------------


def long_fem_case(folder: Path) -> Path:
    """Two 17 m rod cars (P2, 128 elements each) meeting through a Kelvin–Voigt coupler, 300 s of motion: about 30 s of
    compiled stepping here, one call of the kernel before the loop was chunked."""
    body = {"type": "rod", "length": 17.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}
    data = {
        "kind": "impact",
        "cars": [{"name": "rear", "body": {**body, "mass_per_length": 7000.0}, "velocity": 1.8, "sensors": {"center": 0.0}},
                 {"name": "front", "body": {**body, "mass_per_length": 5900.0}, "velocity": 0.0, "sensors": {"center": 0.0}}],
        "couplers": [{"name": "c1", "between": ["rear", "front"], "law": {"kelvin_voigt": {"stiffness": 5.0e7, "damping": 2.0e5}}}],
        "time": {"end": 300.0, "output_stride": 100},
        "models": ["fem"],
        "fem": {"elements": 128, "order": 2},
    }
    path = folder / "long.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_stops_a_long_fem_run_within_two_seconds(signum, code, tmp_path):
    """SIGINT (Ctrl-C) or SIGTERM half a second into the compiled stepping of a 30 s fem run: before, the kernel ran to
    its end (52.9 s after the Ctrl-C on this machine); now the process is gone within 2 s, exit 130 or 143, one
    ``interrupted`` line, nothing under the output name and no temporary."""
    output = tmp_path / "out.h5"
    env = {**os.environ, "FEMREF_BUDGET": "1000", "OPENBLAS_NUM_THREADS": "1"}
    command = [sys.executable, "-c", "from femref.cli import main; main()", "--progress", "run", str(long_fem_case(tmp_path)), "-o", str(output)]
    run = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        for line in run.stderr:  # until the stepping has begun
            if line.strip() == "fem: running":
                break
        time.sleep(0.5)
        sent = time.monotonic()
        run.send_signal(signum)
        stderr = run.stderr.read()
        run.wait(timeout=60)
        stopped_after = time.monotonic() - sent
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == code and stopped_after < 2.0, (run.returncode, stopped_after, stderr)
    assert stderr.splitlines()[-1] == f"interrupted ({signal.Signals(signum).name}): stopped; no file is left half-written", stderr
    assert "Traceback" not in stderr and not output.exists() and temporaries_of(output) == []
