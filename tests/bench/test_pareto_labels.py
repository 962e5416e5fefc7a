"""The Pareto plot's configuration labels never overlap (femref.bench.output.place_labels).

Before, every Pareto-optimal point was labelled at one fixed offset (6 pt right, 6 pt up), so
points close in time and error had their labels drawn over each other. Checked with the
renderer's own boxes (``get_window_extent``) on the default scene's bench and on a dense
hand-made front.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib.image
import matplotlib.pyplot as plt
import pytest

from femref.bench.configurations import Configuration
from femref.bench.output import LABEL_GID, pareto_figure, plot_pareto
from femref.bench.pareto import pareto_mask
from femref.bench.run import BenchOutcome, BenchRow, run_bench
from femref.case import parse_case
from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
from femref.scene.build import scene_from_case


def label_boxes(fig) -> list:
    """The window extents of the figure's configuration labels (renderer boxes, pixels)."""
    renderer = fig.canvas.get_renderer()
    return [text.get_window_extent(renderer) for ax in fig.axes for text in ax.texts if text.get_gid() == LABEL_GID]


def overlapping_pairs(boxes: list) -> list[tuple[int, int]]:
    return [(i, j) for i in range(len(boxes)) for j in range(i + 1, len(boxes)) if boxes[i].overlaps(boxes[j])]


def fixed_offset_overlaps(fig, points, texts) -> int:
    """How many label pairs overlap when every label sits 6 pt right and 6 pt up of its point (the old placement)."""
    ax = fig.axes[0]
    renderer = fig.canvas.get_renderer()
    labels = [ax.annotate(t, p, textcoords="offset points", xytext=(6, 6), fontsize=8) for p, t in zip(points, texts)]
    boxes = [label.get_window_extent(renderer) for label in labels]
    for label in labels:
        label.remove()
    return len(overlapping_pairs(boxes))


@pytest.fixture(scope="module")
def default_bench() -> BenchOutcome:
    """The bench of the built-in default scene (``femref bench`` with no case), one repeat (~6 s)."""
    case = parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE)
    return run_bench(scene_from_case(case), repeats=1)


def test_no_two_labels_overlap_on_the_default_bench(default_bench, tmp_path):
    fig = pareto_figure(default_bench, "femref bench <default scene>")
    try:
        boxes = label_boxes(fig)
        assert len(boxes) == len(default_bench.pareto_rows) >= 3
        assert overlapping_pairs(boxes) == []
        frame = fig.axes[0].get_window_extent(fig.canvas.get_renderer())
        assert all(frame.x0 <= b.x0 and b.x1 <= frame.x1 and frame.y0 <= b.y0 and b.y1 <= frame.y1 for b in boxes)  # none clipped
    finally:
        plt.close(fig)
    assert matplotlib.image.imread(plot_pareto(tmp_path / "bench.png", default_bench)).ndim == 3


def dense_front(n: int = 12) -> BenchOutcome:
    """``n`` Pareto-optimal configurations 2 % apart in time and 5 % apart in error, a few dominated ones near
    them, and the two ends of the front decades away (rigid: fast and rough; a fine fem: slow and exact)."""
    rows = [BenchRow(Configuration("fem", "solve", "elements", 4 * (k + 1)), wall_times_s=(1e-3 * 1.02**k,), peak_error=0.05 * 0.95**k)
            for k in range(n)]
    rows += [BenchRow(Configuration("rigid", "solve"), wall_times_s=(1e-5,), peak_error=0.5),
             BenchRow(Configuration("fem", "solve", "elements", 512), wall_times_s=(1.0,), peak_error=1e-6)]
    rows += [BenchRow(Configuration("modal", "solve", "modes", k + 1), wall_times_s=(1.1e-3 * 1.02**k,), peak_error=0.06 * 0.95**k)
             for k in range(4)]
    for row, optimal in zip(rows, pareto_mask([r.wall_time_s for r in rows], [r.peak_error for r in rows])):
        row.pareto = bool(optimal)
    return BenchOutcome(SimpleNamespace(reference_description="hand-made"), rows, 1, 1.0, 10)


def test_labels_of_a_dense_front_are_spread_apart():
    """Twelve labels within a tenth of a decade: at the old fixed offset most overlap their neighbours; placed, none do."""
    outcome = dense_front()
    fig = pareto_figure(outcome)
    try:
        boxes = label_boxes(fig)
        front = [row for row in outcome.rows if row.pareto]
        assert len(boxes) == len(front) == 14
        assert overlapping_pairs(boxes) == []
        points = [(row.wall_time_s, row.peak_error) for row in front]
        assert fixed_offset_overlaps(fig, points, [row.configuration.label for row in front]) >= 10
    finally:
        plt.close(fig)


@pytest.mark.filterwarnings("ignore:Attempting to set identical low and high ylims")  # one point: matplotlib widens the axis itself
def test_a_front_of_one_point_and_no_front_still_plot(tmp_path):
    one = BenchOutcome(SimpleNamespace(reference_description="hand-made"),
                       [BenchRow(Configuration("rigid", "solve"), wall_times_s=(0.01,), peak_error=0.05, pareto=True),
                        BenchRow(Configuration("ann_x", "estimator"), wall_times_s=(0.02,), peak_error=math.nan)], 1, 1.0, 10)
    fig = pareto_figure(one)
    try:
        assert len(label_boxes(fig)) == 1
    finally:
        plt.close(fig)
    none = BenchOutcome(SimpleNamespace(reference_description="hand-made"),
                        [BenchRow(Configuration("ann_x", "estimator"), wall_times_s=(0.02,), peak_error=math.nan)], 1, 1.0, 10)
    assert matplotlib.image.imread(plot_pareto(tmp_path / "none.png", none)).ndim == 3
