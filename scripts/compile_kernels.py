"""Compile femref's impact kernels ahead of a first run: the kernels a run of the built-in default scene loads.

    python scripts/compile_kernels.py              # into this install's cache folder (make demo, after its install)
    python scripts/compile_kernels.py --into DIR   # into a scratch cache, then copied to DIR (scripts/femref_build.py)

With ``--into`` (a wheel) the kernels of a sweep's batched runs are compiled too (about 18 s of CPU more), so that
a first ``femref sweep`` after ``pip install .`` loads them; the demo needs only the single-run loop.

While it compiles it prints the first run's notice ("compiling femref's impact kernels, once
(about N s; cached in DIR)"); with the kernels already cached it says so. ``--into`` copies the
cache folder's entries, its stamp and the measured compile time to DIR, which the build backend
puts in the wheel as ``femref/impact/kernels/_compiled`` (femref.impact.kernels.cache.COMPILED).
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import sys
import tempfile
from pathlib import Path


def compile_default_loop(batched: bool = False) -> Path:
    """Load (compiling if needed) the impact loop as ``femref run`` of the default scene does, and with ``batched`` the
    kernels of a sweep's batched runs (:func:`femref.sweep.batch.load_batch_kernels`); its cache folder."""
    from femref.case import parse_case
    from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
    from femref.impact.kernels import cache
    from femref.run import load_compiled_loop
    from femref.scene.build import scene_from_case

    scene = scene_from_case(parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE), Path.cwd())
    load_compiled_loop(scene)
    if batched:
        from femref.sweep.batch import load_batch_kernels

        load_batch_kernels(scene)
    return cache.cache_directory()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--into", type=Path, help="copy the compiled kernels to this folder (compiled in a scratch cache)")
    args = parser.parse_args()
    notices = logging.getLogger("femref.compile")
    notices.addHandler(logging.StreamHandler(sys.stderr))
    notices.setLevel(logging.INFO)
    with tempfile.TemporaryDirectory() as scratch:
        if args.into:
            os.environ["NUMBA_CACHE_DIR"] = scratch  # before numba is imported: a cache of this build only
        from femref.impact.kernels import cache

        folder = compile_default_loop(batched=args.into is not None)
        if not args.into:
            print(f"femref's impact kernels are compiled (cached in {folder})", file=sys.stderr)
            return
        args.into.mkdir(parents=True, exist_ok=True)
        for path in [*folder.glob("*.nbi"), *folder.glob("*.nbc"), folder / cache.STAMP_FILE, folder / cache.SECONDS_FILE]:
            if path.exists():  # compile.seconds only where this process compiled
                shutil.copyfile(path, args.into / path.name)


if __name__ == "__main__":
    main()
