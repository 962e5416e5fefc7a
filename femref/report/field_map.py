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
    """The map of ``model.fields`` with the rigid translation removed (x horizontal in m, t upward in s, colour the
    elastic displacement in mm, :func:`elastic_displacement`); None without fields."""
    fields = model.fields
    if not {"x", "u", "time"} <= fields.keys():
        return None
    title = f"elastic displacement field — {model.name}"
    try:
        elastic, translation = elastic_displacement(fields["x"], fields["u"])
    except ValueError as error:
        return Picture(title, "", None, f"no field picture: {error}")
    caption = (
        f"Space–time map of the {model.name} elastic displacement u(x, t) − ū(t): position x (m) across, time t (s) "
        "upward, colour in mm. ū(t) is the length-weighted mean of u over the body — its rigid translation, "
        f"removed so that the elastic wave shows (exactly the mass-weighted mean on a uniform body); ū spans "
        f"{1e3 * float(np.min(translation)):.3g} to {1e3 * float(np.max(translation)):.3g} mm."
    )
    try:
        png = render_space_time_png(fields["x"], fields["time"], elastic, label="u − ū (mm)")
    except RenderUnavailable as error:
        return Picture(title, caption, None, f"no field picture: {error}")
    except (RuntimeError, ValueError, OSError) as error:  # VTK reports its failures as these
        return Picture(title, caption, None, f"no field picture: rendering failed ({type(error).__name__}: {error})")
    return Picture(title, caption, png)


def elastic_displacement(x: NDArray, u: NDArray) -> tuple[NDArray, NDArray]:
    """``(u − ū, ū)`` of a field ``u[t, x]`` (m) at the ascending positions ``x`` (m).

    ``ū(t) = ∫ u(x, t) dx / L`` by the trapezoidal rule on the stored nodes: the mean
    displacement per unit length, the car's rigid translation (its mass-weighted mean on a
    uniform body; the report reads files only and the file stores no mass). Subtracting it
    leaves the elastic displacement, whose wave the rigid motion would otherwise hide.
    Raises ValueError when ``x`` and ``u`` do not fit or ``x`` has no length.
    """
    x = np.asarray(x, dtype=float)
    u = np.asarray(u, dtype=float)
    if u.ndim != 2 or u.shape[1] != x.size:
        raise ValueError(f"the field has shape {u.shape}, expected (times, {x.size}) for {x.size} positions")
    order = np.argsort(x)
    length = float(x[order[-1]] - x[order[0]]) if x.size else 0.0
    if not length > 0.0:
        raise ValueError("the field's positions span no length")
    values, dx = u[:, order], np.diff(x[order])
    translation = (0.5 * (values[:, 1:] + values[:, :-1])) @ dx / length  # trapezoidal rule (numpy 1.26 has no trapezoid)
    return u - translation[:, None], translation


def render_space_time_png(x: NDArray, times: NDArray, u: NDArray, label: str = "u (mm)") -> bytes:
    """PNG bytes of ``u[t, x]`` (m, drawn in mm under ``label``) on a StructuredGrid in normalised coordinates, axes
    labelled in x (m) and t (s).

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
    values = 1e3 * np.asarray(u, dtype=float)
    grid.point_data[label] = values.ravel(order="F")  # VTK structured points: first axis fastest
    extent = float(np.max(np.abs(values))) or 1.0  # a colour scale symmetric about zero: white is no displacement
    plotter = pv.Plotter(off_screen=True, window_size=WINDOW_SIZE)
    try:
        plotter.set_background("white")
        plotter.add_mesh(grid, scalars=label, cmap="coolwarm", clim=(-extent, extent), scalar_bar_args={"title": label, "color": "black", "vertical": True, "fmt": "%.3g"})
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
