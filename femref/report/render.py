"""Off-screen pictures of FEM fields with pyvista (EGL/Mesa, no display needed).

A missing EGL makes VTK crash the process instead of raising, so availability is probed
once in a subprocess (:func:`offscreen_status`); callers degrade with its message.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

_PROBE = """
import os
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
import pyvista as pv
pv.OFF_SCREEN = True
plotter = pv.Plotter(off_screen=True, window_size=(32, 32))
plotter.add_mesh(pv.Sphere())
image = plotter.screenshot(return_img=True)
plotter.close()
assert image.shape[0] == 32
"""


class RenderUnavailable(RuntimeError):
    """Off-screen rendering cannot work on this machine; the message says what to install."""


@functools.lru_cache(maxsize=1)
def offscreen_status() -> tuple[bool, str]:
    """(True, "") when pyvista renders off-screen here, else (False, the reason and the fix)."""
    try:
        done = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        return False, "off-screen rendering probe timed out"
    if done.returncode == 0:
        return True, ""
    tail = (done.stderr or "").strip().splitlines()[-1:] or [f"exit code {done.returncode}"]
    return False, (
        f"pyvista cannot render off-screen ({tail[0]}); install EGL/Mesa "
        "(Debian: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri) or run scripts/install-offscreen-gl.sh"
    )
