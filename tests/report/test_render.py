"""Off-screen rendering with pyvista works headless, or says clearly why not."""

import io

import numpy as np
import pytest

from femref.report.field_map import render_space_time_png
from femref.report.render import RenderUnavailable, offscreen_status


def test_space_time_map_renders_or_degrades_clearly(tmp_path):
    x = np.linspace(-8.0, 8.0, 30)
    t = np.linspace(0.0, 0.3, 40)
    u = np.sin(x)[None, :] * t[:, None]
    ok, reason = offscreen_status()
    if not ok:
        assert "install" in reason
        with pytest.raises(RenderUnavailable, match="off-screen"):
            render_space_time_png(x, t, u)
        return
    png = render_space_time_png(x, t, u)
    import matplotlib.image

    image = matplotlib.image.imread(io.BytesIO(png))
    assert image.shape[0] > 100 and image.shape[1] > 100
    assert np.ptp(image[..., :3]) > 0.5  # a coloured map, not a blank canvas
