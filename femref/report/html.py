"""The self-contained report page: facts, model choice, scores, failed models, plots, field map, case.

The page is XHTML-compatible HTML5 (void elements self-closed, every text escaped with
:func:`html.escape`), has no scripts and no external files: images are PNG data URIs. It
names files by their name (or their path below the result file's folder), never by a
local absolute path (:func:`hide_local_paths`).

Scores (``<quantity>_<statistic>_error_<item>``, :mod:`femref.run.scoring`) are grouped so
that they read at laptop width: a summary table (reference, wall time, speed-up and every
worst-item aggregate ``…_error_max``), then one small table per coupler and per probe.
"""

from __future__ import annotations

import base64
import math
import re
from dataclasses import dataclass, replace
from html import escape
from pathlib import Path, PurePosixPath
from typing import Any, Iterable

from femref.report.figures import Picture
from femref.report.read import Choice, Epsilon, ResultFile
from femref.results import UNDEFINED

STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1100px; padding: 0 1em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; }
th { background: #f3f3f3; vertical-align: bottom; max-width: 7em; }
th[scope="row"] { max-width: none; text-align: left; white-space: nowrap; }
td.num { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
table.facts th { text-align: left; max-width: none; }
div.wide { overflow-x: auto; }
table.scores { margin: 0.4em 0 0.8em; } table.scores caption { text-align: left; font-weight: 600; padding: 0.2em 0; }
details { margin: 0.6em 0; } details > summary { cursor: pointer; font-weight: 600; }
div.items { display: flex; flex-wrap: wrap; gap: 0 1.5em; align-items: flex-start; }
tr.chosen th, tr.chosen td { background: #eef6e8; font-weight: 600; }
p.verdict { font-size: 1.05em; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; }
p.problem { color: #a33; }
pre { background: #f7f7f7; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
""".strip()

LEADING_METRICS = ("reference", "wall_time_s", "speedup")
METRIC_NAME = re.compile(r"^(?P<quantity>.+?)_(?P<statistic>max|rms_in_range|rms|peak_time|peak)_error_(?P<item>.+)$")
QUANTITY_LABELS = {
    "coupler_force": "force",
    "acceleration": "acceleration",
    "vertical_acceleration": "vertical acceleration",
    "pitch_rate": "pitch rate",
    "axial_force": "axial force",
}
STATISTIC_LABELS = {"peak": "peak error", "peak_time": "peak time error", "rms": "rms error", "rms_in_range": "rms error in range",
                    "max": "max error"}
COUPLER_QUANTITY = "coupler_force"
LOCAL_PATH = re.compile(r"(?<![\w.~/-])(?:/[^\s/'\",:{}\[\]<>]+(?: [^\s/'\",:{}\[\]<>]+)*){2,}")
"""An absolute POSIX path of at least two components, not part of a longer word (``m/s`` is not one); a component
may hold single spaces (``/home/ann smith/yard``), so a folder name with a space is not left half shown."""


def render_page(result: ResultFile, plots: list[Picture], field_maps: list[Picture]) -> str:
    """The whole page as one string."""
    folder = result.path.resolve().parent
    body = []
    if result.choice is not None:
        body += ['<h2 id="choice">Model choice</h2>', _choice_section(result.choice)]
    body += [
        '<h2 id="scores">Scores</h2>',
        _scores_section(result),
        _models_section(result, folder),
        '<h2 id="plots">Plots</h2>',
        pictures_html(plots, "no plots: the file holds no model output to draw"),
    ]
    if field_maps:  # a rendering failure's message may quote a library's path
        field_maps = [replace(p, problem=hide_local_paths(p.problem, folder)) for p in field_maps]
        body += ['<h2 id="field">FEM field</h2>', pictures_html(field_maps, "")]
    body += ['<h2 id="case">Resolved case</h2>', f"<pre>{escape(hide_local_paths(result.case_yaml, folder))}</pre>"]
    return page(f"femref report — {result.path.name}", _facts(result, result.epsilon), body)


def page(title: str, facts: list[tuple[str, str]], body: Iterable[str]) -> str:
    """A whole page: ``title`` as its heading, the ``facts`` table, then ``body`` (empty parts left out)."""
    head = f'<head><meta charset="utf-8"/><title>{escape(title)}</title><style>{STYLE}</style></head>'
    parts = [f"<h1>{escape(title)}</h1>", '<table class="facts">' + "".join(table_row((k,), (v,)) for k, v in facts) + "</table>", *body]
    return "<!DOCTYPE html>\n<html lang=\"en\">\n" + head + "\n<body>\n" + "\n".join(p for p in parts if p) + "\n</body>\n</html>\n"


def table_row(heads: Iterable[Any] = (), cells: Iterable[Any] = ()) -> str:
    """One row of ``<th>`` then ``<td>`` cells, each escaped."""
    return "<tr>" + "".join(f"<th>{escape(str(c))}</th>" for c in heads) + "".join(f"<td>{escape(str(c))}</td>" for c in cells) + "</tr>"


def _facts(result: ResultFile, epsilon: Epsilon) -> list[tuple[str, str]]:
    if epsilon.value is not None:
        eps = f"{epsilon.value:.3g} (ε = (T_wave/T_load)²; the quasi-rigid models need ε ≪ 1)"
    else:
        eps = f"not available: {epsilon.problem}"
    return [("result file", result.path.name), ("scene", result.kind), ("ε", eps), ("femref version", result.femref_version),
            ("created", result.created)]


def hide_local_paths(text: str, folder: Path) -> str:
    """``text`` with every absolute path shown relative to ``folder`` (the result file's) when below it, else by
    its file name: a page carries no local path."""

    def shown(match: re.Match) -> str:
        path = PurePosixPath(match.group(0))
        try:
            return path.relative_to(folder.as_posix()).as_posix()
        except ValueError:
            return path.name

    return LOCAL_PATH.sub(shown, text)


def _choice_section(choice: Choice) -> str:
    """The chosen model, its estimate against the tolerance, and the ladder climbed."""
    verdict = "within" if choice.met else "NOT within"
    what = f"{choice.output} ({choice.output_description})" if choice.output_description else choice.output
    sentence = (
        f"Chosen model: <strong>{escape(choice.chosen)}</strong> — estimated error "
        f"<strong>{escape(_percent(choice.estimate))}</strong> of {escape(what)}, {verdict} the tolerance "
        f"<strong>{escape(_percent(choice.tolerance))}</strong>"
        + (f" (basis: {escape(choice.basis)})" if choice.basis else "")
        + "."
    )
    if not choice.met:
        sentence += " No rung of the ladder is expected within the tolerance; the most accurate run is kept."
    if math.isfinite(choice.epsilon_load):
        sentence += f" ε_load = {choice.epsilon_load:.3g} (from the rigid and quasi-rigid runs)."
    columns = ("", "rung", "family", "resolution", "predicted cost", "wall time", "peak force (kN)", "estimated error", "basis")
    header = "".join(f"<th>{escape(c)}</th>" for c in columns)
    rows = []
    for rung in choice.rungs:
        chosen = rung.label == choice.chosen
        numbers = [
            str(rung.resolution) if rung.resolution else "–",
            f"{rung.predicted_cost_us * 1e-3:.3g} ms" if math.isfinite(rung.predicted_cost_us) else "–",
            _seconds(rung.wall_time_s) if rung.ran else "not run",
            f"{rung.peak_coupler_force / 1e3:.1f}" if math.isfinite(rung.peak_coupler_force) else "–",
            _percent(rung.estimate),
        ]
        numeric = "".join(f'<td class="num">{escape(c)}</td>' for c in numbers)
        basis = rung.basis if not rung.status or rung.status == "ok" else f"{rung.status}: {rung.basis}"
        row_class, mark = (' class="chosen"', "→") if chosen else ("", "")
        rows.append(f'<tr{row_class}><td>{mark}</td><th scope="row">{escape(rung.label)}</th><td>{escape(rung.family)}</td>{numeric}'
                    f"<td>{escape(basis)}</td></tr>")
    note = (
        "<p>The ladder, cheapest predicted cost first (the cost model's time on the machine that fitted it: only "
        "ratios matter); resolution: elements per car (fem) or modes (modal); → marks the chosen rung; not run: the "
        "climb did not need the rung. A tolerance run stores no scores against a reference: each run's error is "
        "estimated instead.</p>"
    )
    table = f'<table class="ladder"><thead><tr>{header}</tr></thead><tbody>{"".join(rows)}</tbody></table>'
    return f'<p class="verdict">{sentence}</p>\n{note}\n<div class="wide">{table}</div>'


def _percent(value: float) -> str:
    return f"{100.0 * value:.3g} %" if math.isfinite(value) else "–"


@dataclass(frozen=True)
class MetricName:
    """A score attribute's name split as ``<quantity>_<statistic>_error_<item>`` (None parts: not of that form)."""

    name: str
    quantity: str | None = None
    statistic: str | None = None
    item: str | None = None

    @classmethod
    def parse(cls, name: str) -> "MetricName":
        found = METRIC_NAME.match(name)
        return cls(name, *found.group("quantity", "statistic", "item")) if found else cls(name)

    @property
    def aggregate(self) -> bool:
        """The maximum over the items (``…_error_max``)."""
        return self.item == "max"

    @property
    def of_coupler(self) -> bool:
        return self.quantity == COUPLER_QUANTITY

    def label(self) -> str:
        """A short column header, e.g. ``force peak error (worst coupler)``, ``measured acceleration rms error``."""
        if self.quantity is None:
            return {"wall_time_s": "wall time", "speedup": "speed-up", "outside_range_fraction": "share outside range"}.get(self.name, self.name.replace("_", " "))
        base = self.quantity.removeprefix("measured_")
        quantity = ("measured " if base != self.quantity else "") + QUANTITY_LABELS.get(base, base.replace("_", " "))
        text = f"{quantity} {STATISTIC_LABELS.get(self.statistic, self.statistic)}"
        return f"{text} (worst {'coupler' if self.of_coupler else 'probe'})" if self.aggregate else text

    def order(self) -> tuple:
        """Sort key: couplers first, then quantities as listed, simulated before measured, statistics as listed."""
        base = (self.quantity or "").removeprefix("measured_")
        quantities = list(QUANTITY_LABELS)
        return (
            base != COUPLER_QUANTITY,
            (self.quantity or "").startswith("measured_"),
            quantities.index(base) if base in quantities else len(quantities),
            base,
            list(STATISTIC_LABELS).index(self.statistic) if self.statistic in STATISTIC_LABELS else len(STATISTIC_LABELS),
        )


def metric_columns(scores: dict[str, dict[str, Any]]) -> list[str]:
    """The summary's columns: reference, wall time, speed-up, the worst-item aggregates, then any attribute that
    is not a per-item error."""
    names = {name for metrics in scores.values() for name in metrics if not is_self_check(name)} - {UNDEFINED, IN_RANGE_DEGENERATE}
    parsed = [MetricName.parse(n) for n in names]
    leading = [n for n in LEADING_METRICS if n in names]
    aggregates = [m.name for m in sorted((m for m in parsed if m.aggregate), key=lambda m: (m.order(), m.name))]
    rest = sorted(m.name for m in parsed if m.quantity is None and m.name not in leading)
    return leading + aggregates + rest


#: The score femref.run.scoring.in_range_errors writes when a run's in-range part is degenerate (the report sits below
#: the runner and reads the name, not the module; tests/run/test_in_range_degenerate.py holds the two equal).
IN_RANGE_DEGENERATE = "in_range_degenerate"


def _in_range_notes(scores: dict[str, dict[str, Any]]) -> list[str]:
    """One paragraph per run whose in-range part is degenerate (it does not hold the impact: ``in_range_degenerate``,
    femref.run.scoring.in_range_errors): no in-range scores, and why — told in a sentence, not a score column."""
    return [f'<p class="in-range"><strong>{escape(model)}: no in-range scores</strong> — the in-range part is degenerate, '
            f"{escape(str(metrics[IN_RANGE_DEGENERATE]))}.</p>"
            for model, metrics in scores.items() if IN_RANGE_DEGENERATE in metrics]


def is_self_check(name: str) -> bool:
    """A fact of the reference's check of itself (``reference_warning``, ``reference_error_estimate_<item>``,
    ``self_check`` …, femref.run.runner.check_reference): told in a sentence, not a score column."""
    return name != "reference" and name.startswith(("reference_", "self_check"))


def _self_check_notes(scores: dict[str, dict[str, Any]]) -> list[str]:
    """One paragraph per model that checked its own discretisation: why, the runs, the estimate of its own peak
    error (Richardson, or a lower bound outside the asymptotic range) and the estimate per coupler or probe."""
    notes = []
    for model, metrics in scores.items():
        if "reference_warning" not in metrics:
            continue
        estimate = metrics.get("reference_error_estimate")
        if isinstance(estimate, float) and math.isfinite(estimate):
            bound = metrics.get("reference_error_bound") == "lower"
            told = f"its own peak error is {'at least' if bound else 'estimated at'} {format_metric('reference_error_estimate', estimate)}"
            told += f" ({metrics.get('reference_error_basis', '')})" if metrics.get("reference_error_basis") else ""
        else:
            told = "no estimate (the finer run failed or nothing peaks)"
        items = [(n.removeprefix("reference_error_estimate_"), v) for n, v in metrics.items() if n.startswith("reference_error_estimate_")]
        per_item = "; per item: " + ", ".join(f"{item} {format_metric('error', v)}" for item, v in items) if len(items) > 1 else ""
        wall = metrics.get("self_check_wall_time_s")
        cost = f", {format_metric('wall_time_s', wall)}" if isinstance(wall, float) else ""
        notes.append(f'<p class="self-check"><strong>{escape(model)} checked itself</strong> ({escape(str(metrics.get("self_check", "")))}{escape(cost)}): '
                     f"{escape(str(metrics['reference_warning']))}; {escape(told + per_item)}.</p>")
    return notes


def item_columns(scores: dict[str, dict[str, Any]]) -> dict[str, list[str]]:
    """Per-item errors grouped by item (a coupler or a probe; couplers first, then probes in order of
    appearance), each item's metrics in the summary's order."""
    parsed = [MetricName.parse(n) for metrics in scores.values() for n in metrics if n != UNDEFINED and not is_self_check(n)]
    per_item = list({m.name: m for m in parsed if m.item is not None and not m.aggregate}.values())
    items = sorted(dict.fromkeys(m.item for m in per_item), key=lambda item: not any(m.of_coupler for m in per_item if m.item == item))
    return {item: [m.name for m in sorted((m for m in per_item if m.item == item), key=lambda m: (m.order(), m.name))] for item in items}


def format_metric(name: str, value: Any) -> str:
    """A score value for the table: relative errors in %, peak-time errors in ms, wall time in s."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    if math.isnan(value):
        return "n/a"
    if name == "wall_time_s":
        return f"{value:.3g} s"
    if name == "speedup":
        return f"{value:.3g}×"
    if "time_error" in name:
        return f"{1e3 * value:+.3g} ms"
    if "error" in name or name.endswith("_fraction"):
        return f"{100.0 * value:.3g} %"
    return f"{value:.4g}"


def _scores_section(result: ResultFile) -> str:
    scores = result.scores
    if not scores:
        if result.choice is not None:
            return "<p>No scores: a tolerance run estimates each run's error instead (Model choice above).</p>"
        return "<p>No scores in the file (no reference model ran, or only one model).</p>"
    note = (
        "<p>Relative errors in %; peak-time errors signed, in ms; speed-up = reference wall time / model wall time; "
        "n/a = undefined: the reference signal vanishes (hover for the reason). The summary shows each error's worst "
        "coupler or probe; the tables below give every coupler and probe. A run with quasi-rigid cars that leave their "
        "range (shaded in the plots) is also scored in range: over the samples outside the shaded intervals, unless that "
        "part does not hold the impact (less than a quarter of the contact, e.g. only the ringing after separation): "
        "then its in-range scores are n/a and a line says why.</p>"
    )
    parts = [note, *_self_check_notes(scores), *_in_range_notes(scores), _score_table(scores, metric_columns(scores), "summary", "summary")]
    items = item_columns(scores)
    couplers = {item: names for item, names in items.items() if any(MetricName.parse(n).of_coupler for n in names)}
    probes = {item: names for item, names in items.items() if item not in couplers}
    for kind, group, is_open in (("coupler", couplers, True), ("probe", probes, False)):
        if not group:
            continue
        tables = "".join(_score_table(scores, names, f"{kind} {item}", "item") for item, names in group.items())
        heading = f"Per {kind} ({len(group)}): {', '.join(group)}"
        opened = ' open="open"' if is_open else ""
        parts.append(f'<details{opened} class="{kind}s"><summary>{escape(heading)}</summary><div class="items">{tables}</div></details>')
    return "\n".join(parts)


def _score_table(scores: dict[str, dict[str, Any]], columns: list[str], caption: str, kind: str) -> str:
    header = "<th>model</th>" + "".join(f'<th title="{escape(c)}">{escape(MetricName.parse(c).label())}</th>' for c in columns)
    rows = []
    for model, metrics in scores.items():
        if not any(c in metrics for c in columns):
            continue
        reasons = undefined_reasons(metrics)
        cells = "".join(_score_cell(c, metrics, reasons) for c in columns)
        rows.append(f'<tr><th scope="row">{escape(model)}</th>{cells}</tr>')
    return (
        f'<div class="wide"><table class="scores {kind}"><caption>{escape(caption)}</caption>'
        f'<thead><tr>{header}</tr></thead><tbody>{"".join(rows)}</tbody></table></div>'
    )


def undefined_reasons(metrics: dict[str, Any]) -> dict[str, str]:
    """Metric → why it is undefined, from the scores' ``undefined`` attribute (``name: reason; …``)."""
    text = metrics.get(UNDEFINED, "")
    return dict(item.split(": ", 1) for item in text.split("; ") if ": " in item) if isinstance(text, str) else {}


def _score_cell(column: str, metrics: dict[str, Any], reasons: dict[str, str]) -> str:
    if column not in metrics:
        return '<td class="num">–</td>'
    reason = reasons.get(column)
    title = f' title="{escape(reason)}"' if reason else ""
    return f'<td class="num"{title}>{escape(format_metric(column, metrics[column]))}</td>'


def _models_section(result: ResultFile, folder: Path) -> str:
    """Every model's status and wall time; failed models listed with their message."""
    chosen = result.choice.chosen if result.choice is not None else None
    rows = "".join(
        f'<tr><th scope="row">{escape(m.name)}{" (chosen)" if m.name == chosen else ""}</th>'
        f"<td>{escape(m.status)}</td>"
        f"<td class=\"num\">{escape(_seconds(m.wall_time_s))}</td></tr>"
        for m in result.models.values()
    )
    parts = ['<h2 id="models">Models</h2>', f"<table><thead><tr><th>model</th><th>status</th><th>wall time</th></tr></thead><tbody>{rows}</tbody></table>"]
    failed = result.failed_models
    if failed:
        items = "".join(f"<li><strong>{escape(m.name)}</strong>: {escape(hide_local_paths(m.message, folder) or '(no message)')}</li>" for m in failed)
        parts += ["<h3>Failed models</h3>", f'<ul class="failed">{items}</ul>']
    return "\n".join(parts)


def _seconds(value: float) -> str:
    return "–" if math.isnan(value) else f"{value:.3g} s"


def pictures_html(pictures: Iterable[Picture], empty: str) -> str:
    parts = [_picture(p) for p in pictures]
    if not parts and empty:
        return f"<p>{escape(empty)}</p>"
    return "\n".join(parts)


def _picture(picture: Picture) -> str:
    if picture.png is None:
        return f'<p class="problem">{escape(picture.problem or "picture unavailable")}</p>'
    source = "data:image/png;base64," + base64.b64encode(picture.png).decode("ascii")
    return (
        f'<figure><img src="{source}" alt="{escape(picture.title)}"/>'
        f"<figcaption>{escape(picture.caption)}</figcaption></figure>"
    )
