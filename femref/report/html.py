"""The self-contained report page: facts, score table, failed models, plots, field map, case.

The page is XHTML-compatible HTML5 (void elements self-closed, every text escaped with
:func:`html.escape`), has no scripts and no external files: images are PNG data URIs.
"""

from __future__ import annotations

import base64
import math
from html import escape
from typing import Any, Iterable

from femref.report.figures import Picture
from femref.report.read import Epsilon, ResultFile
from femref.results import UNDEFINED

STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1100px; padding: 0 1em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; }
th { background: #f3f3f3; vertical-align: bottom; max-width: 7em; }
td.num { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
table.facts th { text-align: left; max-width: none; }
div.wide { overflow-x: auto; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; }
p.problem { color: #a33; }
pre { background: #f7f7f7; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
""".strip()

LEADING_METRICS = ("reference", "wall_time_s", "speedup")


def render_page(result: ResultFile, plots: list[Picture], field_maps: list[Picture]) -> str:
    """The whole page as one string."""
    title = f"femref report — {result.path.name}"
    body = [
        f"<h1>{escape(title)}</h1>",
        _facts(result, result.epsilon),
        "<h2>Scores</h2>",
        _score_table(result.scores),
        _models_section(result),
        "<h2>Plots</h2>",
        _pictures(plots, "no plots: the file holds no model output to draw"),
    ]
    if field_maps:
        body += ["<h2>FEM field</h2>", _pictures(field_maps, "")]
    body += ["<h2>Resolved case</h2>", f"<pre>{escape(result.case_yaml)}</pre>"]
    head = f'<head><meta charset="utf-8"/><title>{escape(title)}</title><style>{STYLE}</style></head>'
    return "<!DOCTYPE html>\n<html lang=\"en\">\n" + head + "\n<body>\n" + "\n".join(body) + "\n</body>\n</html>\n"


def _facts(result: ResultFile, epsilon: Epsilon) -> str:
    if epsilon.value is not None:
        eps = f"{epsilon.value:.3g} (ε = (T_wave/T_load)²; the quasi-rigid models need ε ≪ 1)"
    else:
        eps = f"not available: {epsilon.problem}"
    rows = [
        ("result file", str(result.path)),
        ("scene", result.kind),
        ("ε", eps),
        ("femref version", result.femref_version),
        ("created", result.created),
    ]
    cells = "".join(f"<tr><th>{escape(k)}</th><td>{escape(v)}</td></tr>" for k, v in rows)
    return f'<table class="facts">{cells}</table>'


def metric_columns(scores: dict[str, dict[str, Any]]) -> list[str]:
    """Score attributes as columns: reference, wall time, speed-up, the ``_max`` aggregates, then the rest."""
    names = {name for metrics in scores.values() for name in metrics} - {UNDEFINED}
    leading = [n for n in LEADING_METRICS if n in names]
    aggregates = sorted(n for n in names if n.endswith("_max") and n not in leading)
    rest = sorted(names - set(leading) - set(aggregates))
    return leading + aggregates + rest


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
    if "error" in name:
        return f"{100.0 * value:.3g} %"
    return f"{value:.4g}"


def _score_table(scores: dict[str, dict[str, Any]]) -> str:
    if not scores:
        return "<p>No scores in the file (no reference model ran, or only one model).</p>"
    columns = metric_columns(scores)
    header = "<th>model</th>" + "".join(f'<th title="{escape(c)}">{escape(c.replace("_", " "))}</th>' for c in columns)
    rows = []
    for model, metrics in scores.items():
        reasons = undefined_reasons(metrics)
        cells = "".join(_score_cell(c, metrics, reasons) for c in columns)
        rows.append(f"<tr><th>{escape(model)}</th>{cells}</tr>")
    note = (
        "<p>Relative errors in %; peak-time errors signed, in ms; speed-up = reference wall time / model wall time; "
        "n/a = undefined: the reference signal vanishes (hover for the reason).</p>"
    )
    return f'{note}<div class="wide"><table class="scores"><thead><tr>{header}</tr></thead><tbody>{"".join(rows)}</tbody></table></div>'


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


def _models_section(result: ResultFile) -> str:
    """Every model's status and wall time; failed models listed with their message."""
    rows = "".join(
        f"<tr><th>{escape(m.name)}</th><td>{escape(m.status)}</td><td class=\"num\">{escape(_seconds(m.wall_time_s))}</td></tr>"
        for m in result.models.values()
    )
    parts = ["<h2>Models</h2>", f"<table><thead><tr><th>model</th><th>status</th><th>wall time</th></tr></thead><tbody>{rows}</tbody></table>"]
    failed = result.failed_models
    if failed:
        items = "".join(f"<li><strong>{escape(m.name)}</strong>: {escape(m.message or '(no message)')}</li>" for m in failed)
        parts += ["<h3>Failed models</h3>", f'<ul class="failed">{items}</ul>']
    return "\n".join(parts)


def _seconds(value: float) -> str:
    return "–" if math.isnan(value) else f"{value:.3g} s"


def _pictures(pictures: Iterable[Picture], empty: str) -> str:
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
