"""The compiled kernels' cache: where it lives, what it is keyed on, and what a first run says while it compiles.

* the folder is femref's choice — ``NUMBA_CACHE_DIR``, else ``$XDG_CACHE_HOME/femref``, else
  ``~/.cache/femref`` — named by numba's rule for the package's folder (checked against the
  rule written out here), so a read-only site-packages is never asked to hold it;
* femref's locator serves only the package's own functions, stamps them with the engine stamp,
  and steps aside (numba's own fallback) when its folder cannot be made;
* a second process is served from the cache; a stale stamp removes the cached code and the
  kernel compiles afresh; :func:`~femref.impact.kernels.cache.cached` says no for an empty cache without compiling;
* :func:`femref.run.runner.load_compiled_loop` logs the one-off notice only when it compiles, with
  the compile time measured on this machine once there is one, and the CLI prints it.
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import numba
import pytest
from rich.console import Console

import femref
from femref.cli.common import model_progress
from femref.impact.kernels import cache, engine_stamp, pool
from femref.impact.kernels.loop import ENTRY_POINTS  # imported before any test points numba's cache folder elsewhere
from femref.run import runner

REPO = Path(femref.__file__).resolve().parents[1]
PACKAGE = REPO / "femref" / "impact" / "kernels"


def numba_folder_name(folder: Path) -> str:
    """numba's cache subfolder for the functions of ``folder``: its name and the SHA-1 of its absolute path."""
    return f"{folder.name}_{hashlib.sha1(str(folder.absolute()).encode()).hexdigest()}"


def test_the_cache_folder_is_numba_cache_dir_else_xdg_cache_home_else_the_home_cache(monkeypatch, tmp_path: Path):
    monkeypatch.setattr(numba.config, "CACHE_DIR", "")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.cache_root() == tmp_path / "xdg" / "femref"
    assert cache.cache_directory() == tmp_path / "xdg" / "femref" / numba_folder_name(PACKAGE)
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.cache_root() == tmp_path / "home" / ".cache" / "femref"
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "numba"))
    assert cache.cache_directory() == tmp_path / "numba" / numba_folder_name(PACKAGE)


def test_the_locator_serves_the_package_with_the_engine_stamp_and_steps_aside_elsewhere(monkeypatch, tmp_path: Path):
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "cache"))
    locator = cache.KernelCacheLocator.from_function(pool.dot.py_func, pool.__file__)
    assert locator.get_cache_path() == str(cache.cache_directory()) and (tmp_path / "cache").is_dir()
    assert locator.get_source_stamp() == engine_stamp()

    def elsewhere():
        return 0

    assert cache.KernelCacheLocator.from_function(elsewhere, __file__) is None  # not a kernel: numba's own locators
    (tmp_path / "file").write_text("")
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "file"))  # a folder that cannot be made
    assert cache.KernelCacheLocator.from_function(pool.dot.py_func, pool.__file__) is None


PROBE = """
import json
import numpy as np
from femref.impact.kernels import cache, pool
from femref.impact.kernels.loop import ENTRY_POINTS
value = pool.dot(np.arange(4.0), 0, 2, 2)
print(json.dumps({"value": value, "hits": sum(pool.dot.stats.cache_hits.values()), "misses": sum(pool.dot.stats.cache_misses.values()),
                  "folder": str(cache.cache_directory()), "used": pool.dot.stats.cache_path, "loop_cached": cache.cached(ENTRY_POINTS)}))
"""


def probe(xdg: Path) -> dict:
    """Run :data:`PROBE` in a fresh process whose cache home is ``xdg`` (``NUMBA_CACHE_DIR`` unset)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(XDG_CACHE_HOME=str(xdg), PYTHONPATH=os.pathsep.join([str(REPO), str(REPO / "tests")]))
    done = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_second_process_is_served_from_the_cache_home_and_a_stale_stamp_compiles_afresh(tmp_path: Path):
    first = probe(tmp_path)
    folder = Path(first["folder"])
    assert first["value"] == 0.0 * 2.0 + 1.0 * 3.0 and first["misses"] == 1 and first["hits"] == 0
    assert folder == tmp_path / "femref" / numba_folder_name(PACKAGE) and first["used"] == str(folder)
    assert list(folder.glob("pool.dot-*.nbi")) and (folder / cache.STAMP_FILE).read_text() == engine_stamp()
    assert first["loop_cached"] is False  # an empty cache: the loop would compile (and nothing compiled it here)
    second = probe(tmp_path)
    assert second["hits"] == 1 and second["misses"] == 0
    (folder / cache.STAMP_FILE).write_text("written by other sources")
    third = probe(tmp_path)
    assert third["hits"] == 0 and third["misses"] == 1 and (folder / cache.STAMP_FILE).read_text() == engine_stamp()


@pytest.fixture
def unloaded_loop(monkeypatch, tmp_path: Path):
    """``load_compiled_loop`` as in a fresh process, its cache folder under ``tmp_path`` and no stepping."""
    monkeypatch.setattr(runner, "_loop_loaded", False)
    monkeypatch.setattr(runner, "step_cars", lambda *args: None)
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    (tmp_path / cache.cache_directory().name).mkdir()
    from femref.case import parse_case
    from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
    from femref.scene.build import scene_from_case

    return scene_from_case(parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE), tmp_path)


def test_load_compiled_loop_says_why_it_waits_only_when_it_compiles(monkeypatch, caplog, unloaded_loop):
    answers = iter([False, True])  # not cached before the step, cached after it
    monkeypatch.setattr(cache, "cached", lambda dispatchers: next(answers))
    with caplog.at_level(logging.INFO, logger="femref.compile"):
        runner.load_compiled_loop(unloaded_loop)
    expected = f"compiling femref's impact kernels, once (about {cache.COMPILE_SECONDS:.0f} s; cached in {cache.cache_directory()})"
    assert [r.getMessage() for r in caplog.records] == [expected]
    assert 0.0 <= cache.compile_seconds() < cache.COMPILE_SECONDS  # this compile's time, measured, for the next notice
    caplog.clear()
    monkeypatch.setattr(runner, "_loop_loaded", False)
    monkeypatch.setattr(cache, "cached", lambda dispatchers: True)
    with caplog.at_level(logging.INFO, logger="femref.compile"):
        runner.load_compiled_loop(unloaded_loop)
    assert caplog.records == []  # a warm cache: nothing said


def test_the_cli_prints_the_compile_notice_while_models_run_and_not_after():
    out = io.StringIO()
    console = Console(file=out, width=60)
    logger = logging.getLogger("femref.compile")
    level = logger.level
    with model_progress(console) as progress_for:
        assert progress_for("fem") is None  # no progress asked for: only the notice is printed
        logger.info("compiling femref's impact kernels, once (about %.0f s; cached in %s)", 42.0, "/a/folder/" + "x" * 60)
    logger.info("said after the run")
    assert out.getvalue() == f"compiling femref's impact kernels, once (about 42 s; cached in /a/folder/{'x' * 60})\n"  # one line
    assert logger.level == level and not logger.handlers


def test_after_a_run_the_loop_is_cached_for_this_machine():
    from femref.case import parse_case
    from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
    from femref.scene import ModelRun
    from femref.scene.build import scene_from_case

    scene = scene_from_case(parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE), Path.cwd())
    runner.step_cars(scene, ModelRun("rigid", ("rigid",) * len(scene.cars)), scene.contact_time() / 100.0)
    assert cache.cached(ENTRY_POINTS)  # every entry point run (compiled or loaded) is in the cache folder
    assert all(Path(dispatcher.stats.cache_path) == cache.cache_directory() for dispatcher in ENTRY_POINTS)
