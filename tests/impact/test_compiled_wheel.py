"""Kernels compiled ahead of time: a wheel carries them, and another install of the same sources loads them.

* the engine stamp names sources relative to the folder femref is imported from, so a copy of
  the sources elsewhere (the build folder against site-packages) has the same stamp, and an
  edited copy another;
* kernels compiled by one copy of the tree, placed as another copy's ``_compiled`` folder, are
  loaded there — numba's own hit counter says so — and not when their stamp is another's;
* the build backend (``scripts/femref_build.py``) adds what the compile wrote to the wheel and
  to its RECORD (rows checked by decoding them), builds the wheel unchanged when the compile
  fails or is switched off, and asks for the compile's dependencies only when it compiles.
"""

from __future__ import annotations

import base64
import hashlib
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import femref
from femref.impact.kernels import cache, engine_stamp

REPO = Path(femref.__file__).resolve().parents[1]
KERNELS = Path("femref", "impact", "kernels")


def tree_copy(folder: Path) -> Path:
    """femref and reduced copied to ``folder`` (no byte code)."""
    for package in ("femref", "reduced"):
        shutil.copytree(REPO / package, folder / package, ignore=shutil.ignore_patterns("__pycache__", "_compiled"))
    return folder


PROBE = """
import json
import numpy as np
from femref.impact.kernels import cache, engine_stamp, pool
value = pool.dot(np.arange(4.0), 0, 2, 2)
print(json.dumps({"stamp": engine_stamp(), "hits": sum(pool.dot.stats.cache_hits.values()),
                  "misses": sum(pool.dot.stats.cache_misses.values()), "folder": str(cache.cache_directory())}))
"""


def probe(tree: Path, cache_home: Path) -> dict:
    """Run :data:`PROBE` in a fresh process importing femref from ``tree``, its cache home ``cache_home``."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(XDG_CACHE_HOME=str(cache_home), PYTHONPATH=str(tree), PYTHONDONTWRITEBYTECODE="1")
    done = subprocess.run([sys.executable, "-c", PROBE], env=env, cwd=tree, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_kernels_compiled_by_one_copy_of_the_sources_are_loaded_by_another_and_only_with_their_stamp(tmp_path: Path):
    built = probe(tree_copy(tmp_path / "build"), tmp_path / "build-cache")
    assert built["stamp"] == engine_stamp() and built["misses"] == 1  # the stamp does not name the folder
    installed = tree_copy(tmp_path / "site")
    shutil.copytree(built["folder"], installed / KERNELS / "_compiled")  # as the wheel carries them
    first = probe(installed, tmp_path / "cache")
    assert first["hits"] == 1 and first["misses"] == 0 and Path(first["folder"]).parent == tmp_path / "cache" / "femref"
    assert first["folder"] != built["folder"]  # its own cache folder, seeded from _compiled
    (installed / KERNELS / "_compiled" / cache.STAMP_FILE).write_text("compiled from other sources")
    other = probe(installed, tmp_path / "other-cache")
    assert other["hits"] == 0 and other["misses"] == 1  # not loaded: compiled afresh
    with open(installed / KERNELS / "pool.py", "a") as source:
        source.write("\n# an edit\n")
    assert probe(installed, tmp_path / "edited-cache")["stamp"] != engine_stamp()


def test_refresh_cache_copies_the_compiled_kernels_only_into_a_folder_of_other_sources(monkeypatch, tmp_path: Path):
    compiled = tmp_path / "compiled"
    compiled.mkdir()
    (compiled / cache.STAMP_FILE).write_text(engine_stamp())
    (compiled / "pool.dot-1.py311.nbi").write_bytes(b"index")
    monkeypatch.setattr(cache, "COMPILED", compiled)
    monkeypatch.setattr(cache.numba.config, "CACHE_DIR", str(tmp_path / "cache"))
    folder = cache.cache_directory()
    cache.refresh_cache()
    assert (folder / "pool.dot-1.py311.nbi").read_bytes() == b"index" and (folder / cache.STAMP_FILE).read_text() == engine_stamp()
    (folder / "pool.dot-1.py311.nbi").write_bytes(b"compiled here")
    cache.refresh_cache()  # the folder's stamp is current: its entries are its own
    assert (folder / "pool.dot-1.py311.nbi").read_bytes() == b"compiled here"
    (folder / cache.STAMP_FILE).write_text("other sources")
    (compiled / cache.STAMP_FILE).write_text("other sources too")
    cache.refresh_cache()
    assert not list(folder.glob("*.nbi")) and not list(folder.glob("*.partial"))


@pytest.fixture
def backend(monkeypatch, tmp_path: Path):
    """scripts/femref_build.py with setuptools' wheel replaced by a small one (one module and its RECORD)."""
    spec = importlib.util.spec_from_file_location("femref_build_under_test", REPO / "scripts" / "femref_build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    def setuptools_wheel(wheel_directory, config_settings=None, metadata_directory=None) -> str:
        with zipfile.ZipFile(Path(wheel_directory) / "femref-0.1.0-py3-none-any.whl", "w") as wheel:
            wheel.writestr("femref/__init__.py", "x = 1\n")
            wheel.writestr("femref-0.1.0.dist-info/RECORD", "femref/__init__.py,sha256=abc,6\nfemref-0.1.0.dist-info/RECORD,,\n")
        return "femref-0.1.0-py3-none-any.whl"

    monkeypatch.setattr(module.setuptools_backend, "build_wheel", setuptools_wheel)
    monkeypatch.delenv("FEMREF_COMPILE_AT_BUILD", raising=False)
    monkeypatch.chdir(REPO)  # setuptools reads the project from the working folder, as pip runs it
    return module


def writes(script: str):
    """A compile command running ``script`` with the target folder as ``sys.argv[1]``."""
    return lambda into: [sys.executable, "-c", script, str(into)]


def test_the_backend_adds_the_compiled_kernels_to_the_wheel_and_its_record(monkeypatch, tmp_path: Path, backend):
    script = "import pathlib, sys; d = pathlib.Path(sys.argv[1]); (d / 'a.nbi').write_bytes(b'i' * 5); (d / 'kernels.stamp').write_text('s')"
    monkeypatch.setattr(backend, "compile_command", writes(script))
    wheel = tmp_path / backend.build_wheel(str(tmp_path))
    with zipfile.ZipFile(wheel) as archive:
        assert archive.read("femref/impact/kernels/_compiled/a.nbi") == b"iiiii"
        assert archive.read("femref/__init__.py") == b"x = 1\n"
        rows = {row.split(",")[0]: row.split(",")[1:] for row in archive.read("femref-0.1.0.dist-info/RECORD").decode().splitlines()}
        for name in ("femref/impact/kernels/_compiled/a.nbi", "femref/impact/kernels/_compiled/kernels.stamp"):
            algorithm, encoded = rows[name][0].split("=", 1)
            content = archive.read(name)
            assert algorithm == "sha256" and base64.urlsafe_b64decode(encoded + "=" * (-len(encoded) % 4)) == hashlib.sha256(content).digest()
            assert int(rows[name][1]) == len(content)
    assert rows["femref/__init__.py"] == ["sha256=abc", "6"] and rows["femref-0.1.0.dist-info/RECORD"] == ["", ""]


def test_a_failed_compile_or_none_asked_for_leaves_the_wheel_as_setuptools_built_it(monkeypatch, tmp_path: Path, backend, capsys):
    monkeypatch.setattr(backend, "compile_command", writes("raise SystemExit('no numba here')"))
    name = backend.build_wheel(str(tmp_path))
    with zipfile.ZipFile(tmp_path / name) as archive:
        assert archive.namelist() == ["femref/__init__.py", "femref-0.1.0.dist-info/RECORD"]
    said = capsys.readouterr().err
    assert "warning: the kernels were not compiled (exit 1); the first run compiles them" in said and "no numba here" in said
    monkeypatch.setenv("FEMREF_COMPILE_AT_BUILD", "0")
    monkeypatch.setattr(backend, "compile_command", lambda into: pytest.fail("compiled though switched off"))
    backend.build_wheel(str(tmp_path / ".."))
    assert backend.get_requires_for_build_wheel() == backend.setuptools_backend.get_requires_for_build_wheel()


def test_the_build_asks_for_every_distribution_the_compile_imports_at_the_projects_bounds(backend):
    names = {spec.split(">")[0].split("=")[0].split("[")[0].lower() for spec in backend.compile_requirements()}
    assert names == set(backend.COMPILE_NEEDS)
    assert set(backend.compile_requirements()) <= set(backend.get_requires_for_build_wheel())
