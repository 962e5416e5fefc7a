"""Start-up a user does not notice (issue 31): ``femref run`` imports what its case uses and no more — the modules
held, not the seconds. ``scipy.signal`` (with ``scipy.stats``, about 0.5 s of CPU) only where a signal tool runs, ``scipy.optimize``
and ``scipy.integrate`` only where a root, a fit or an adaptive quadrature is sought (benchmarks/bench_startup.py measures the CPU)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import yaml

from femref.case.defaults import default_scene_data

from support.paths import REPO

#: scipy's subpackages that cost a quarter to half a second each to import, and what pulls them in.
SIGNAL_TOOLS = ("scipy.signal", "scipy.stats", "scipy.ndimage")
SOLVERS = ("scipy.optimize", "scipy.integrate", "scipy.interpolate")


def imported_after(script: str) -> set[str]:
    """The modules in ``sys.modules`` after ``script`` runs in a fresh interpreter."""
    code = f"{script}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return set(json.loads(done.stdout.splitlines()[-1]))


def run_imports(tmp_path: Path, data: dict) -> set[str]:
    """The modules ``femref run`` of the case ``data`` has imported when it is done (it wrote its result)."""
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(data))
    output = tmp_path / "out.h5"
    script = "\n".join([
        "from femref.cli import main",
        "try:",
        f"    main(['run', {str(case)!r}, '-o', {str(output)!r}])",
        "except SystemExit as done:",
        "    assert done.code == 0, done.code",
    ])
    modules = imported_after(script)
    assert output.is_file()
    return modules


def coarse_default_scene() -> dict:
    """The default scene (four models, the measurement chain with its 100 Hz low-pass, both inverse estimators), coarse
    and short."""
    data = default_scene_data()
    data["fem"]["elements"] = 8
    data["time"] = {"end": 0.1}
    return data


def test_validating_and_planning_the_default_scene_imports_no_signal_tools_or_solvers() -> None:
    """``femref validate`` and the plan of ``femref run`` (case parsed, scene built, budget checked): none of scipy's
    signal tools or solvers, and not numba (the compiled loop is loaded when the first car steps)."""
    modules = imported_after("\n".join([
        "from pathlib import Path",
        "from femref.case import parse_case, resolved_yaml",
        "from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data",
        "from femref.flow import plan_case",
        "case = parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE)",
        "resolved_yaml(case)",
        "plan_case(case, Path.cwd(), 'default scene')",
    ]))
    loaded = sorted(m for m in (*SIGNAL_TOOLS, *SOLVERS, "numba") if m in modules)
    assert not loaded, f"validating and planning imported {loaded}: import them in the function that uses them"
    assert "femref.flow" in modules and "pydantic" in modules


def test_run_of_the_default_scene_imports_no_signal_tools_or_solvers(tmp_path) -> None:
    """The default scene filters its records (the measurement chain's own low-pass, femref.sensing.measurement) and
    its inverse_quasi_rigid integrates the car's profiles (a fixed Gauss–Legendre rule,
    femref.estimators.inverse.quasi_rigid_inversion): none of scipy's signal tools or solvers."""
    modules = run_imports(tmp_path, coarse_default_scene())
    loaded = sorted(m for m in (*SIGNAL_TOOLS, *SOLVERS) if m in modules)
    assert not loaded, f"femref run of the default scene imported {loaded}"
    assert "femref.estimators.inverse" in modules  # the test can fail: the estimators ran


def test_run_of_models_without_estimators_imports_no_solvers(tmp_path) -> None:
    """The default scene's four models (fem, modal, quasi_rigid, rigid) and its measurement chain, without estimators:
    none of scipy's signal tools or solvers."""
    data = coarse_default_scene()
    data.pop("estimators")
    modules = run_imports(tmp_path, data)
    loaded = sorted(m for m in (*SIGNAL_TOOLS, *SOLVERS) if m in modules)
    assert not loaded, f"femref run of models that need no signal tool imported {loaded}"
    assert "numba" in modules and "femref.fem.operators" in modules  # the test can fail: the fem cars were built


def test_one_off_imports_are_loaded_before_the_runs_that_import_them() -> None:
    """femref.run.runner.ONE_OFF_IMPORTS holds true: a single-body transient's rigid and quasi_rigid models import
    scipy.integrate and scipy.signal when they run (not before); and in a fresh interpreter run_scene loads them
    before any model is timed: no model's timing imports a scipy subpackage."""
    scene = "\n".join([
        "import dataclasses, json, sys",
        "from femref.case import load_case",
        "from femref.models import model_form",
        "from femref.run import runner",
        "from femref.scene.build import scene_from_case",
        f"scene = scene_from_case(load_case({str(REPO / 'cases' / 'rod_transient_half_sine.yaml')!r}), None)",
        "def scipy_now():",
        "    return {m for m in sys.modules if m.startswith('scipy.')}",
    ])
    each_model = "\n".join([
        scene,
        "scene = dataclasses.replace(scene, dt=runner.single_body_time_step(scene)[0])",
        "seen = {}",
        "for name in ('rigid', 'quasi_rigid'):",
        "    before = scipy_now()",
        "    model_form(name, 'transient')(scene)",
        "    seen[name] = sorted(scipy_now() - before)",
        "print(json.dumps(seen))",
    ])
    timed_runs = "\n".join([
        scene,
        "timed = []",
        "capture = runner.capture",
        "def watched(name, work):",
        "    before = scipy_now()",
        "    result = capture(name, work)",
        "    timed.extend(scipy_now() - before)",
        "    return result",
        "runner.capture = watched",
        "runner.run_scene(scene)",
        "print(json.dumps(sorted(timed)))",
    ])
    seen, timed = (json.loads(printed(script)) for script in (each_model, timed_runs))
    assert "scipy.integrate" in seen["rigid"] and "scipy.signal" not in seen["rigid"]
    assert "scipy.signal" in seen["quasi_rigid"]
    assert not timed, f"a model's timing imported scipy's {sorted({m.split('.')[1] for m in timed})}"


def printed(script: str) -> str:
    """The last line ``script`` prints in a fresh interpreter."""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=REPO, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.splitlines()[-1]


def test_run_leaves_the_collector_as_it_was_and_freezes_it_at_exit(tmp_path) -> None:
    """``femref run`` in-process leaves the garbage collector as it was when it returns — on with nothing frozen (a test
    session keeps collecting), or off when it was off — though it froze it once per run when the runs began
    (femref.cli.run.start_up_uncollected); and it freezes it at the process's exit (femref.cli.run.freeze_at_exit: an
    exit handler registered before the runs, so run after theirs, finds the objects frozen), once however many runs."""
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(coarse_default_scene() | {"models": ["rigid"], "estimators": []}))
    script = "\n".join([
        "import atexit, gc, types",
        "import femref.cli.run as command",
        "calls = []",
        "def freeze():",
        "    calls.append(gc.get_freeze_count())",
        "    gc.freeze()",
        "names = ('disable', 'enable', 'isenabled', 'get_freeze_count', 'unfreeze')",
        "command.gc = types.SimpleNamespace(freeze=freeze, **{name: getattr(gc, name) for name in names})",
        "atexit.register(lambda: print('at exit:', len(calls), gc.get_freeze_count() > 0))",
        "from femref.cli import main",
        "def run():",
        "    try:",
        f"        main(['run', {str(case)!r}, '-o', {str(tmp_path / 'out.h5')!r}])",
        "    except SystemExit as done:",
        "        assert done.code == 0, done.code",
        "for _ in range(3):",
        "    run()",
        "print('after the runs:', len(calls), gc.get_freeze_count(), gc.isenabled())",
        "gc.disable()",
        "run()",
        "print('collector off:', len(calls), gc.get_freeze_count(), gc.isenabled())",
    ])
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=REPO, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    said = [line for line in done.stdout.splitlines() if line.startswith(("after the runs:", "collector off:", "at exit:"))]
    assert said == ["after the runs: 3 0 True", "collector off: 4 0 False", "at exit: 5 True"]


def test_the_start_up_of_a_run_is_not_collected(tmp_path) -> None:
    """``femref run`` of the default scene (coarse) in a fresh process: no full collection (generation 2) from the
    command's start to its end — the start-up (imports, validation, scene, the compiled loop's load) runs with the
    collector off, and the runs' collections traverse only what the runs make (femref.cli.run.start_up_uncollected) —
    yet young collections run (the collector is on during the runs)."""
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(coarse_default_scene()))
    script = "\n".join([
        "import gc, json",
        "from femref.cli import main",
        "collections = [0, 0, 0]",
        "gc.callbacks.append(lambda phase, info: phase == 'start' and collections.__setitem__(info['generation'], collections[info['generation']] + 1))",
        "try:",
        f"    main(['run', {str(case)!r}, '-o', {str(tmp_path / 'out.h5')!r}])",
        "except SystemExit as done:",
        "    assert done.code == 0, done.code",
        "print(json.dumps(collections))",
    ])
    young, middle, full = json.loads(printed(script))
    assert full == 0, f"{full} full collection(s) during femref run: the start-up was collected"
    assert young > 0  # the test can fail: the collector was on during the runs


def test_the_compiled_loop_loads_uncollected_and_compiles_collected(tmp_path) -> None:
    """``femref run`` loads a cached compiled loop with the collector still off (start-up), but compiles one with it on
    (numba's compiler leaves cyclic garbage): femref.run.runner.compiled_loop_cached decides, as it would be told."""
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(coarse_default_scene() | {"models": ["rigid"], "estimators": []}))
    seen = {}
    for cached in (True, False):
        script = "\n".join([
            "import gc",
            "import femref.run",
            "from femref.run import runner",
            "from femref.cli import main",
            "on = []",
            "load = femref.run.load_compiled_loop",
            "def watched(scene):",
            "    on.append(gc.isenabled())",
            "    load(scene)",
            "femref.run.load_compiled_loop = watched",
            f"runner.compiled_loop_cached = lambda: {cached}",
            "try:",
            f"    main(['run', {str(case)!r}, '-o', {str(tmp_path / 'out.h5')!r}])",
            "except SystemExit as done:",
            "    assert done.code == 0, done.code",
            "print(on[0])",
        ])
        seen[cached] = printed(script)
    assert seen == {True: "False", False: "True"}


def test_compiled_loop_cached_reads_numbas_cache(tmp_path) -> None:
    """An empty cache folder (NUMBA_CACHE_DIR): the loop would compile, and it is said before anything compiles."""
    script = "from femref.run.runner import compiled_loop_cached\nprint(compiled_loop_cached())"
    empty = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=REPO, timeout=600,
                           env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)})
    assert empty.returncode == 0, empty.stderr[-3000:]
    assert empty.stdout.split() == ["False"]
