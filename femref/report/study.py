"""The report page of a network study's ``study.h5`` (:mod:`femref.study.run`): the error table and,
per network, its training loss against the epoch.

Read with h5py only, drawn with the figures' Agg helpers, assembled like the result-file page
(:mod:`femref.report.html`). The loss is ``E`` of :mod:`ann.backprop` (half the mean squared error
of the scaled log target plus the L2 penalty), drawn on a log axis; a network that records no
loss per epoch (an RBF network, solved by least squares; an lbfgs-trained MLP) says so instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from html import escape
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref.report.figures import MODEL_COLORS, Picture, new_figure, figure_png
from femref.report.html import hide_local_paths, page, pictures_html, table_row
from femref.report.read import attr_value, attrs_of

NETWORKS_GROUP = "networks"


@dataclass
class NetworkData:
    """One trained network of the study: its attributes (source, network, file, errors) and loss per epoch."""

    name: str
    attrs: dict[str, Any]
    loss_curve: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))


@dataclass
class SetErrors:
    """Every estimator's error summary on one evaluation set: estimator → attrs (mean, p95, bias, samples)."""

    name: str
    summaries: dict[str, dict[str, Any]]


def is_study_file(h5: h5py.File) -> bool:
    """Whether an open femref file is a network study's ``study.h5``."""
    return "study_yaml" in h5.attrs and NETWORKS_GROUP in h5


def study_report(path: Path, h5: h5py.File) -> str:
    """The whole page of the open study file ``h5`` (read from ``path``): the file by its name, the study's paths
    relative to its folder or by name (:func:`femref.report.html.hide_local_paths`) — a page carries no local path."""
    networks = [_network(name, group) for name, group in h5[NETWORKS_GROUP].items()]
    sets = [SetErrors(name, {e: attrs_of(g.attrs) for e, g in group.items() if isinstance(g, h5py.Group)})
            for name, group in h5.items() if name != NETWORKS_GROUP and isinstance(group, h5py.Group)]
    title = f"femref report — {path.name}"
    facts = [("study file", path.name), ("networks", str(len(networks))), ("evaluation sets", ", ".join(s.name for s in sets) or "none"),
             ("femref version", str(attr_value(h5.attrs.get("femref_version", "unknown"))))]
    body = [
        "<h2>Peak-force errors</h2>",
        _error_table(networks, sets),
        "<h2>Training loss</h2>",
        pictures_html([loss_picture(n) for n in networks], "no networks"),
        "<h2>Study</h2>",
        f"<pre>{escape(hide_local_paths(str(attr_value(h5.attrs['study_yaml'])), path.resolve().parent))}</pre>",
    ]
    return page(title, facts, body)


def _network(name: str, group: h5py.Group) -> NetworkData:
    curve = np.asarray(group["loss_curve"][()], dtype=float) if "loss_curve" in group else np.empty(0)  # older files have none
    return NetworkData(name, attrs_of(group.attrs), curve)


def loss_picture(network: NetworkData) -> Picture:
    """Loss against epoch (log axis) of one network, or why there is none."""
    title = f"training loss — {network.name}"
    curve = network.loss_curve
    if curve.size == 0:
        return Picture(title, "", None, f"{network.name}: no loss per epoch recorded (an RBF network is solved by least squares; "
                                              "an lbfgs-trained MLP keeps none)")
    figure, (ax,) = new_figure()
    epochs = np.arange(1, curve.size + 1)
    positive = curve > 0.0
    ax.plot(epochs[positive], curve[positive], color=MODEL_COLORS[1], lw=1.3)
    if np.any(positive):
        ax.set_yscale("log")
    ax.set(xlabel="epoch", ylabel="training loss E (scaled log target)", title=network.name)
    a = network.attrs
    caption = (f"{network.name} (network {a.get('network', '?')}, trained on {a.get('source', '?')} records, "
               f"{a.get('training_samples', '?')} samples): loss per epoch, {curve.size} epochs, last {curve[-1]:.3g}.")
    return Picture(title, caption, figure_png(figure))


def _error_table(networks: list[NetworkData], sets: list[SetErrors]) -> str:
    estimators = list(dict.fromkeys([n.name for n in networks] + [e for s in sets for e in s.summaries]))
    trained = {n.name: n for n in networks}
    head = ["estimator", "trained on", "epochs", "own-source mean"] + [f"{s.name} mean / p95" for s in sets]
    rows = []
    for estimator in estimators:
        network = trained.get(estimator)
        cells = [estimator, network.attrs.get("source", "") if network else "—",
                 str(network.loss_curve.size) if network is not None and network.loss_curve.size else "—",
                 _percent(network.attrs.get("validation_mean_error")) if network else "—"]
        for s in sets:
            summary = s.summaries.get(estimator)
            cells.append(f"{_percent(summary.get('mean'))} / {_percent(summary.get('p95'))}" if summary else "—")
        rows.append(table_row((), cells))
    return f'<div class="wide"><table>{table_row(head)}{"".join(rows)}</table></div>'


def _percent(value: Any) -> str:
    return "—" if value is None or not math.isfinite(float(value)) else f"{float(value):.2%}"


__all__ = ["is_study_file", "loss_picture", "study_report"]
