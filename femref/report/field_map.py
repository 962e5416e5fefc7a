"""A space–time map of a stored displacement field ``u(x, t)``, rendered off-screen with pyvista.

Availability is decided by :func:`femref.report.render.offscreen_status` (probed in a
subprocess, since a missing EGL crashes VTK instead of raising); when rendering is
impossible the picture carries the one-line reason instead of a PNG.
"""

from __future__ import annotations

import io

import numpy as np
from numpy.typing import NDArray

from femref.report.render import RenderUnavailable, offscreen_status
from femref.report.figures import Picture
from femref.report.read import ModelData

WINDOW_SIZE = (900, 700)  # pixels
TIME_ASPECT = 0.75  # height / width of the map in the picture


def field_map_picture(model: ModelData) -> Picture | None:
    """The map of ``model.fields`` (x horizontal in m, t upward in s, colour u in mm); None without fields."""
    fields = model.fields
    if not {"x", "u", "time"} <= fields.keys():
        return None
    title = f"displacement field — {model.name}"
    caption = (
        f"Space–time map of the {model.name} displacement u(x, t): position x (m) across, time t (s) upward, "
        "colour u (mm, rigid-body motion included)."
    )
    try:
        png = render_space_time_png(fields["x"], fields["time"], fields["u"])
    except RenderUnavailable as error:
        return Picture(title, caption, None, f"no field picture: {error}")
    except (RuntimeError, ValueError, OSError) as error:  # VTK reports its failures as these
        return Picture(title, caption, None, f"no field picture: rendering failed ({type(error).__name__}: {error})")
    return Picture(title, caption, png)


def render_space_time_png(x: NDArray, times: NDArray, u: NDArray) -> bytes:
    """PNG bytes of ``u[t, x]`` (m) on a StructuredGrid in normalised coordinates, axes labelled in x (m) and t (s).

    Raises :class:`RenderUnavailable` when pyvista cannot render off-screen here.
    """
    ok, reason = offscreen_status()
    if not ok:
        raise RenderUnavailable(reason)
    import matplotlib.image
    import pyvista as pv

    x = np.asarray(x, dtype=float)
    times = np.asarray(times, dtype=float)
    if x.size < 2 or times.size < 2:
        raise ValueError(f"a map needs at least 2 positions and 2 times, got {x.size} and {times.size}")
    xx, tt = np.meshgrid(x, times)
    span = float(np.ptp(x)) or 1.0
    duration = float(np.ptp(times)) or 1.0
    grid = pv.StructuredGrid((xx - x.min()) / span, TIME_ASPECT * (tt - times.min()) / duration, np.zeros_like(xx))
    label = "u (mm)"
    grid.point_data[label] = 1e3 * np.asarray(u, dtype=float).ravel(order="F")  # VTK structured points: first axis fastest
    plotter = pv.Plotter(off_screen=True, window_size=WINDOW_SIZE)
    try:
        plotter.set_background("white")
        plotter.add_mesh(grid, scalars=label, cmap="coolwarm", scalar_bar_args={"title": label, "color": "black", "vertical": True, "fmt": "%.3g"})
        plotter.show_bounds(
            axes_ranges=[x.min(), x.max(), times.min(), times.max(), 0.0, 0.0],
            xtitle="x (m)",
            ytitle="t (s)",
            ztitle="z",  # VTK refuses an empty title; the z axis is hidden
            show_zaxis=False,
            location="outer",
            color="black",
            fmt="%.3g",
        )
        plotter.view_xy()
        image = plotter.screenshot(return_img=True)
    finally:
        plotter.close()
    buffer = io.BytesIO()
    matplotlib.image.imsave(buffer, image, format="png")
    return buffer.getvalue()
