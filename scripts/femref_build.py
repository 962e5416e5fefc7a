"""femref's build backend: setuptools', and a wheel that carries its impact kernels compiled (pyproject.toml [build-system]).

``pip install .`` builds a wheel; this backend then runs ``scripts/compile_kernels.py --into``
on the source tree in a subprocess and adds what it compiled to the wheel as
``femref/impact/kernels/_compiled/`` (and to the wheel's RECORD), so that the first
``femref run`` after the install loads the kernels rather than compiling them
(femref.impact.kernels.cache.COMPILED). For that the wheel's build environment holds what the
compile imports (:data:`COMPILE_NEEDS`, at the bounds of ``[project] dependencies``).

A failed compile never fails the install: the wheel is built without the kernels, a warning
says why, and the first run compiles them (with its notice). ``FEMREF_COMPILE_AT_BUILD=0``
builds without compiling. Editable installs (``pip install -e .``, make demo) and sdists are
setuptools' own; make demo compiles by ``scripts/compile_kernels.py`` after its install.
"""

from __future__ import annotations

import base64
import hashlib
import os
import re
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

from setuptools import build_meta as setuptools_backend
from setuptools.build_meta import (
    build_editable, build_sdist, get_requires_for_build_editable, get_requires_for_build_sdist, prepare_metadata_for_build_editable,
    prepare_metadata_for_build_wheel,
)

TREE = Path(__file__).resolve().parents[1]
COMPILE_NEEDS = ("numpy", "numba", "scipy", "pydantic", "pyyaml", "h5py", "threadpoolctl")
"""The distributions ``scripts/compile_kernels.py`` imports (the default scene's case, its scene and the impact loop)."""
COMPILED = "femref/impact/kernels/_compiled"
"""Where the wheel carries the compiled kernels (femref.impact.kernels.cache.COMPILED)."""
COMPILE_TIMEOUT = 1800.0
"""Seconds the compile may take before the wheel is built without it (28–77 s measured on 2 busy cores)."""


def compiling() -> bool:
    """Whether wheels are built with their kernels compiled (``FEMREF_COMPILE_AT_BUILD`` not ``0``)."""
    return os.environ.get("FEMREF_COMPILE_AT_BUILD", "1") != "0"


def compile_requirements() -> list[str]:
    """The requirements of ``[project] dependencies`` whose distribution is in :data:`COMPILE_NEEDS`."""
    dependencies = tomllib.loads((TREE / "pyproject.toml").read_text())["project"]["dependencies"]
    return [spec for spec in dependencies if re.match(r"[A-Za-z0-9_.-]+", spec)[0].lower() in COMPILE_NEEDS]


def get_requires_for_build_wheel(config_settings=None) -> list[str]:
    """setuptools' requirements and, when compiling, :func:`compile_requirements`."""
    return setuptools_backend.get_requires_for_build_wheel(config_settings) + (compile_requirements() if compiling() else [])


def compile_command(into: Path) -> list[str]:
    """The command that compiles the kernels into ``into``."""
    return [sys.executable, str(TREE / "scripts" / "compile_kernels.py"), "--into", str(into)]


def compile_kernels(into: Path) -> bool:
    """Run :func:`compile_command` on the source tree in a subprocess; False (and a warning on stderr) if it fails."""
    print("femref: compiling the impact kernels into the wheel (once per build; 30-80 s)", file=sys.stderr, flush=True)
    path = os.pathsep.join(filter(None, [str(TREE), os.environ.get("PYTHONPATH")]))  # the build environment's path kept
    env = {**os.environ, "PYTHONPATH": path, "PYTHONDONTWRITEBYTECODE": "1", "OPENBLAS_NUM_THREADS": "1"}
    try:
        done = subprocess.run(compile_command(into), env=env, cwd=TREE, capture_output=True, text=True, timeout=COMPILE_TIMEOUT, check=False)
    except (OSError, subprocess.TimeoutExpired) as error:
        print(f"femref: warning: the kernels were not compiled ({error}); the first run compiles them", file=sys.stderr)
        return False
    if done.returncode != 0 or not any(into.glob("*.nbi")):
        print(f"femref: warning: the kernels were not compiled (exit {done.returncode}); the first run compiles them\n"
              f"{done.stderr[-2000:]}", file=sys.stderr)
        return False
    return True


def record_line(name: str, content: bytes) -> str:
    """A wheel RECORD row (PEP 376, PEP 427): ``name,sha256=<urlsafe base64 without padding>,size``."""
    digest = base64.urlsafe_b64encode(hashlib.sha256(content).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(content)}"


def add_to_wheel(wheel: Path, files: dict[str, bytes]) -> None:
    """Add ``files`` (archive name → content) to ``wheel`` and its RECORD; the wheel is replaced whole."""
    rewritten = wheel.with_name(wheel.name + ".partial")
    with zipfile.ZipFile(wheel) as old, zipfile.ZipFile(rewritten, "w", zipfile.ZIP_DEFLATED) as new:
        record = next(name for name in old.namelist() if name.endswith(".dist-info/RECORD"))
        for info in old.infolist():
            if info.filename != record:
                new.writestr(info, old.read(info))
        rows = old.read(record).decode().splitlines()
        for name, content in files.items():
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            new.writestr(info, content, zipfile.ZIP_DEFLATED)
            rows.append(record_line(name, content))
        new.writestr(old.getinfo(record), "\n".join(rows) + "\n")
    os.replace(rewritten, wheel)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None) -> str:
    """setuptools' wheel, with the kernels compiled (:func:`compile_kernels`) added under :data:`COMPILED` when they compile."""
    name = setuptools_backend.build_wheel(wheel_directory, config_settings, metadata_directory)
    if compiling():
        with tempfile.TemporaryDirectory() as scratch:
            if compile_kernels(Path(scratch)):
                add_to_wheel(Path(wheel_directory) / name, {f"{COMPILED}/{path.name}": path.read_bytes() for path in sorted(Path(scratch).iterdir())})
    return name


__all__ = [
    "add_to_wheel", "build_editable", "build_sdist", "build_wheel", "compile_kernels", "compile_requirements", "get_requires_for_build_editable",
    "get_requires_for_build_sdist", "get_requires_for_build_wheel", "prepare_metadata_for_build_editable", "prepare_metadata_for_build_wheel",
    "record_line",
]
