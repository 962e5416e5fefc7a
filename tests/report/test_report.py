"""``femref report``: a self-contained, well-formed HTML page of a result file, or exit 2.

Small scenes (8 FEM elements, short ends) are run through the runner and the result
writer, as ``femref run`` does, once per module (the tolerance run through ``femref run
--tolerance``); each page is checked for balanced tags, the score values of the file, PNG
data-URI images (one per expected plot), no local path, the model choice of a tolerance
run, the grouped score tables, the robust y-range of a spiking model's plot and, where a
headless Chromium exists (scripts/install-chromium.sh), that a browser renders the page at
1280 px without console errors or horizontal overflow, keeping a screenshot in ``build/``.
"""

from __future__ import annotations

import base64
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
from html.parser import HTMLParser
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from femref.case import load_case, parse_case, resolved_yaml
from femref.report.render import offscreen_status
from femref.cli.report import report_command
from femref.report.html import format_metric
from femref.report.read import read_result_file
from femref.results import ModelResult, write_results
from femref.run import run_scene
from femref.scene.build import scene_from_case

from support.paths import CASES
VOID = {"meta", "img", "br", "hr", "link", "input", "wbr", "col", "area", "base", "source"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
IMPACT_SENSORS = 5  # hammer: center, front; anvil: rear, center, front
IMPACT_PLOTS = 3 + IMPACT_SENSORS  # coupler force, force against closure, energy balance; one per sensor
SCREENSHOTS = Path(__file__).resolve().parents[2] / "build"  # git-ignored: the browser's screenshots are kept here


def _run_and_write(case, base_dir: Path, output: Path, extra: list[ModelResult] = ()) -> Path:
    outcome = run_scene(scene_from_case(case, base_dir))
    write_results(output, resolved_yaml(case), [*outcome.results, *extra], outcome.scores, scene=outcome.scene.facts())
    return output


def _rod(**overrides) -> dict:
    body = {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2.0e9, "axial_viscosity": 1.0e6}
    return {**body, **overrides}


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """Result files of a small impact (with network and inverse estimators and a failed model),
    a transient with fields and a harmonic scene."""
    folder = tmp_path_factory.mktemp("results")
    impact = load_case(CASES / "impact_ann.yaml")
    impact = parse_case(
        {**_case_data(impact), "fem": {"elements": 8, "order": 2}, "models": ["fem", "quasi_rigid", "rigid"]},
        base_dir=CASES,
    )
    failed = ModelResult.failed("modal", "FloatingPointError: synthetic failure <in the solver>")
    transient = parse_case(
        {
            "kind": "transient",
            "body": _rod(),
            "loads": {"F2": {"half_sine": {"amplitude": -1.0e6, "duration": 0.05}}},
            "time": {"end": 0.1, "dt": 1.0e-3},
            "models": ["fem", "exact", "rigid"],
            "fem": {"elements": 8, "fields": True, "field_stride": 5},
        }
    )
    harmonic = parse_case(
        {
            "kind": "harmonic",
            "body": _rod(),
            "loads": {"F1": 0.0, "F2": 1.0},
            "frequency": {"lambda": {"start": 0.1, "stop": 2.0, "num": 12}},
            "models": ["fem", "exact", "quasi_rigid", "rigid"],
            "fem": {"elements": 8, "order": 2},
        }
    )
    return {
        "impact": _run_and_write(impact, CASES, folder / "impact.h5", [failed]),
        "transient": _run_and_write(transient, folder, folder / "transient.h5"),
        "harmonic": _run_and_write(harmonic, folder, folder / "harmonic.h5"),
        "tolerance": _run_with_tolerance(impact, folder, TOLERANCE),
    }


TOLERANCE = 0.02


def _run_with_tolerance(case, folder: Path, tolerance: float) -> Path:
    """``femref run CASE --tolerance T -o tolerance.h5`` of the impact without its estimators (a ladder climb)."""
    import yaml

    from femref.cli.run import run_command

    data = {key: value for key, value in _case_data(case).items() if key not in ("estimators", "tolerance")}
    case_path = folder / "tolerance.yaml"
    case_path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    output = folder / "tolerance.h5"
    outcome = CliRunner().invoke(run_command, [str(case_path), "--tolerance", str(tolerance), "-o", str(output)])
    assert outcome.exit_code == 0, outcome.output
    return output


def _case_data(case) -> dict:
    import yaml

    return yaml.safe_load(resolved_yaml(case))


@pytest.fixture(scope="module")
def pages(files, tmp_path_factory) -> dict[str, str]:
    """The report page of each result file, written by the command."""
    folder = tmp_path_factory.mktemp("pages")
    pages = {}
    for name, path in files.items():
        output = folder / f"{name}.html"
        result = CliRunner().invoke(report_command, [str(path), "-o", str(output)])
        assert result.exit_code == 0, result.output
        assert result.output.strip() == f"wrote {output}"
        pages[name] = output.read_text(encoding="utf-8")
    return pages


class _TagBalance(HTMLParser):
    """Collects tag-nesting problems and the attributes of every ``<img>``."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.problems: list[str] = []
        self.images: list[dict[str, str | None]] = []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs))
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs))

    def handle_endtag(self, tag):
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.problems.append(f"</{tag}> closes <{self.stack[-1] if self.stack else 'nothing'}>")
            return
        self.stack.pop()


def _images(page: str) -> list[bytes]:
    """Decoded PNGs of the page's images, after checking the page's tags balance."""
    parser = _TagBalance()
    parser.feed(page)
    parser.close()
    assert parser.problems == [] and parser.stack == []
    ET.fromstring(page.split("\n", 1)[1])  # also well-formed XML (after the HTML5 doctype line)
    images = []
    for attrs in parser.images:
        source = attrs.get("src") or ""
        assert source.startswith("data:image/png;base64,")
        assert attrs.get("alt")
        images.append(base64.b64decode(source.split(",", 1)[1], validate=True))
    return images


def _assert_pngs(images: list[bytes], count: int) -> None:
    assert len(images) == count
    for png in images:
        assert png.startswith(PNG_MAGIC) and len(png) > 5_000


def _score_cell(path: Path, model: str, metric: str) -> str:
    with h5py.File(path) as h5:
        value = float(h5[f"scores/{model}"].attrs[metric])
    return f'<td class="num">{format_metric(metric, value)}</td>'


def test_impact_page(files, pages):
    """Impact: coupler force, force against closure, energy balance, one plot per sensor; network estimators and
    the failed model shown."""
    page = pages["impact"]
    _assert_pngs(_images(page), IMPACT_PLOTS)
    with h5py.File(files["impact"]) as h5:
        error = float(h5["scores/rigid"].attrs["coupler_force_peak_error_c1"])
        assert "ann_fem_mlp/couplers/c1/peak_force" in h5 and "ann_fem_mlp/time" not in h5
    assert f'<td class="num">{100 * error:.3g} %</td>' in page
    assert _score_cell(files["impact"], "ann_fem_mlp", "coupler_force_peak_error_c1") in page
    assert "peak only" in page
    assert "<strong>modal</strong>: FloatingPointError: synthetic failure &lt;in the solver&gt;" in page
    with h5py.File(files["impact"]) as h5:
        epsilon = float(h5["scene"].attrs["epsilon"])
    assert f"<th>ε</th><td>{epsilon:.3g} " in page  # as the run stored it
    assert "kind: impact" in page and "femref version" in page


def test_transient_page_with_field_map(files, pages):
    """Transient: one acceleration plot per probe, and the FEM field map (or the one-line reason)."""
    page = pages["transient"]
    ok, reason = offscreen_status()
    images = _images(page)
    _assert_pngs(images, 3 + (1 if ok else 0))
    assert "FEM field" in page
    if not ok:
        assert '<p class="problem">no field picture:' in page
    assert _score_cell(files["transient"], "rigid", "acceleration_max_error_max") in page
    assert "exact (reference)" not in page  # legends live in the images, not the page text


def test_harmonic_page(files, pages):
    """Harmonic: Re/Im against λ, one picture per probe; exact is the reference in the score table."""
    page = pages["harmonic"]
    _assert_pngs(_images(page), 3)
    assert _score_cell(files["harmonic"], "quasi_rigid", "acceleration_rms_error_max") in page
    assert '<td class="num">exact</td>' in page
    assert "FEM field" not in page


def test_default_output_next_to_results(files, tmp_path):
    results = tmp_path / "run1.h5"
    shutil.copy(files["harmonic"], results)
    outcome = CliRunner().invoke(report_command, [str(results)])
    assert outcome.exit_code == 0, outcome.output
    assert outcome.output.strip() == f"wrote {tmp_path / 'run1.html'}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run1.h5", "run1.html"]


def test_report_reads_the_file_and_never_the_case(files, tmp_path):
    """The page shows the ε the run stored in /scene: a stored case that would no longer validate
    does not matter (the report never rebuilds the scene)."""
    results = tmp_path / "old.h5"
    shutil.copy(files["harmonic"], results)
    with h5py.File(results, "a") as h5:
        h5.attrs["case_yaml"] = "kind: harmonic\nbody: {type: rod, length: -1.0}\n"
        epsilon = float(h5["scene"].attrs["epsilon"])
    outcome = CliRunner().invoke(report_command, [str(results)])
    assert outcome.exit_code == 0, outcome.output
    page = (tmp_path / "old.html").read_text(encoding="utf-8")
    assert f"<th>ε</th><td>{epsilon:.3g} " in page
    _assert_pngs(_images(page), 3)


def test_groups_beside_the_models_are_not_models(files, tmp_path):
    """/scores, /scene and a tolerance run's /choice are read as what they are, never listed as models."""
    results = tmp_path / "choice.h5"
    shutil.copy(files["harmonic"], results)
    with h5py.File(results, "a") as h5:
        models = sorted(name for name in h5 if "status" in h5[name].attrs)
        h5.create_group("choice").attrs["chosen"] = "fem"
    assert models and sorted(read_result_file(results).models) == models


def test_file_without_scene_facts_says_so(files, tmp_path):
    """A result file without /scene (written before femref stored it): the page says ε is not recorded."""
    results = tmp_path / "older.h5"
    shutil.copy(files["harmonic"], results)
    with h5py.File(results, "a") as h5:
        del h5["scene"]
    outcome = CliRunner().invoke(report_command, [str(results)])
    assert outcome.exit_code == 0, outcome.output
    page = (tmp_path / "older.html").read_text(encoding="utf-8")
    assert re.search(r"<th>ε</th><td>not available: this result file does not record it", page)


def _not_hdf5(folder: Path) -> Path:
    path = folder / "notes.h5"
    path.write_text("not an HDF5 file\n")
    return path


def _not_femref(folder: Path) -> Path:
    path = folder / "other.h5"
    with h5py.File(path, "w") as h5:
        h5["data"] = np.arange(3.0)
    return path


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda folder: folder / "missing.h5", "result file not found"),
        (_not_hdf5, "not an HDF5 file"),
        (_not_femref, "not a femref result file"),
    ],
    ids=["missing", "not-hdf5", "not-femref"],
)
def test_bad_input_exits_2_and_writes_nothing(tmp_path, make, message):
    results = make(tmp_path)
    before = sorted(tmp_path.iterdir())
    output = tmp_path / "out" / "report.html"
    outcome = CliRunner().invoke(report_command, [str(results), "-o", str(output)])
    assert outcome.exit_code == 2
    assert message in outcome.output and results.name in outcome.output
    assert sorted(tmp_path.iterdir()) == before  # no output, no temporary file, no folder


def test_output_may_not_replace_the_results(files, tmp_path):
    results = tmp_path / "r.h5"
    shutil.copy(files["harmonic"], results)
    outcome = CliRunner().invoke(report_command, [str(results), "-o", str(results)])
    assert outcome.exit_code == 2 and "overwrite" in outcome.output
    assert h5py.is_hdf5(results)


def _tree(page: str) -> ET.Element:
    """The page as an element tree (it is well-formed XML after the HTML5 doctype line)."""
    return ET.fromstring(page.split("\n", 1)[1])


def _text(element: ET.Element) -> str:
    return "".join(element.itertext())


def _captions(page: str) -> dict[str, str]:
    """Every figure's image title (its alt) → its caption."""
    return {figure.find("img").get("alt"): _text(figure.find("figcaption")) for figure in _tree(page).iter("figure")}


def test_tolerance_page_shows_the_choice_and_the_ladder(files, pages):
    """A tolerance run: the chosen model, its estimate against the tolerance and every rung of the ladder (model,
    estimated error, cost) as the file's /choice holds them; ``choice`` is no model and no plot's reference."""
    page, tree = pages["tolerance"], _tree(pages["tolerance"])
    with h5py.File(files["tolerance"]) as h5:
        choice = dict(h5["choice"].attrs)
        labels = [label.decode() for label in h5["choice/label"][()]]
        estimates = h5["choice/estimate"][()]
        costs = h5["choice/predicted_cost"][()]
        models = sorted(name for name in h5 if "status" in h5[name].attrs)
    sections = [_text(h2) for h2 in tree.iter("h2")]
    assert sections[:2] == ["Model choice", "Scores"]
    verdict = _text(tree.find(".//p[@class='verdict']"))
    assert f"Chosen model: {choice['chosen']} — estimated error {100 * choice['estimate']:.3g} %" in verdict
    assert f"within the tolerance {100 * TOLERANCE:.3g} %" in verdict and str(choice["output"]) in verdict
    rows = tree.findall(".//table[@class='ladder']/tbody/tr")
    assert [_text(row.find("th")) for row in rows] == labels
    for row, estimate, cost in zip(rows, estimates, costs):
        cells = [_text(td) for td in row.findall("td")]
        assert f"{cost * 1e-3:.3g} ms" in cells
        assert (f"{100 * estimate:.3g} %" if np.isfinite(estimate) else "–") in cells
    (chosen,) = [row for row in rows if row.get("class") == "chosen"]
    assert _text(chosen.find("th")) == choice["chosen"] and _text(chosen.find("td")) == "→"
    body = list(tree.find("body"))
    models_table = body[body.index(tree.find(".//h2[@id='models']")) + 1]
    listed = [_text(th) for th in models_table.findall("tbody/tr/th")]
    assert sorted(name.removesuffix(" (chosen)") for name in listed) == models and "choice" not in models
    assert f"{choice['chosen']} (chosen)" in listed
    assert "No scores in the file" not in page
    assert all("set by fem_n" in caption for title, caption in _captions(page).items() if title.startswith("acceleration"))


def test_scores_are_grouped_for_a_laptop(files, pages):
    """The scores: a summary of the worst-item errors, then one table per coupler and per probe; every score of
    the file is in exactly one table, and no table is wider than the summary's dozen columns."""
    tree = _tree(pages["impact"])
    tables = tree.findall(".//table")
    scores = [t for t in tables if "scores" in (t.get("class") or "")]
    summary = [t for t in scores if "summary" in t.get("class")]
    assert len(summary) == 1
    summary_titles = [th.get("title") for th in summary[0].findall("thead/tr/th")[1:]]
    assert summary_titles[:3] == ["reference", "wall_time_s", "speedup"]
    assert all(t.endswith("_error_max") for t in summary_titles[3:-1]) and summary_titles[-1] == "outside_range_fraction"
    assert "acceleration_rms_in_range_error_max" in summary_titles  # the quasi-rigid run leaves its range at contact
    captions = [_text(t.find("caption")) for t in scores]
    assert captions == ["summary", "coupler c1", "probe anvil/center", "probe anvil/front", "probe anvil/rear",
                        "probe hammer/center", "probe hammer/front"]
    assert all(len(t.findall("thead/tr/th")) <= 13 for t in scores)
    shown = sorted(th.get("title") for t in scores for th in t.findall("thead/tr/th")[1:])
    with h5py.File(files["impact"]) as h5:
        stored = sorted({name for group in h5["scores"].values() for name in group.attrs} - {"undefined"})
    assert shown == stored
    details = [_text(d.find("summary")) for d in tree.iter("details")]
    assert details == ["Per coupler (1): c1", "Per probe (5): anvil/center, anvil/front, anvil/rear, hammer/center, hammer/front"]


def test_spiking_model_does_not_set_the_plot_range(files, pages):
    """The quasi-rigid accelerations spike at contact onset; the y-range of each acceleration plot is set by fem
    (its 0.5–99.5 % quantiles, with a margin) and the spike is clipped and said to be."""
    captions = {title: caption for title, caption in _captions(pages["impact"]).items() if title.startswith("acceleration — ")}
    assert len(captions) == IMPACT_SENSORS
    clipped_quasi_rigid = 0
    with h5py.File(files["impact"]) as h5:
        for title, caption in captions.items():
            probe = title.removeprefix("acceleration — ")
            found = re.search(r"y-range (\S+) to (\S+) m/s² set by fem ", caption)
            assert found, caption
            lo, hi = map(float, found.groups())
            fem = h5[f"fem/probes/{probe}/acceleration"][()]
            spiking = h5[f"quasi_rigid/probes/{probe}/acceleration"][()]
            q_lo, q_hi = np.quantile(fem, [0.005, 0.995])
            assert lo <= q_lo and hi >= q_hi
            if spiking.max() > hi or spiking.min() < lo:
                assert "clipped, marked by triangles on the edge: " in caption and "quasi_rigid (" in caption
                clipped_quasi_rigid += 1
    assert clipped_quasi_rigid >= 1  # the spike is there, and it is what got clipped


def test_impact_page_draws_hysteresis_and_energy_balance(pages):
    captions = _captions(pages["impact"])
    assert "force against closure" in captions["force against closure — c1"]
    assert "ann_fem_mlp" not in captions["force against closure — c1"]  # a peak estimate has no closure
    assert "total minus its initial total" in captions["energy balance"]


def test_field_map_shows_the_elastic_displacement(pages):
    """The transient's FEM field is drawn with the rigid translation removed (or the page says why not)."""
    page = pages["transient"]
    ok, _ = offscreen_status()
    if ok:
        caption = _captions(page)["elastic displacement field — fem"]
        assert "u(x, t) − ū(t)" in caption and "rigid translation" in caption
    else:
        assert '<p class="problem">no field picture:' in page


def test_no_local_path_in_any_page(files, pages):
    """Pages name files by their name: neither the result folder nor the repository's case folder shows."""
    folders = {str(path.resolve().parent) for path in files.values()} | {str(CASES), str(CASES.parent)}
    for name, page in pages.items():
        assert not [folder for folder in folders if folder in page], name
        assert f"<th>result file</th><td>{files[name].name}</td>" in page
    assert "fem_mlp.npz" in pages["impact"]  # the estimator's network, by its name


def _chromium() -> str | None:
    return next((p for name in ("chromium", "chromium-browser", "google-chrome") if (p := shutil.which(name))), None)


_PROBE = """<script>
var femrefErrors = [];
window.addEventListener("error", function (e) { femrefErrors.push(String(e.message || (e.target && e.target.tagName) || "error")); }, true);
window.addEventListener("load", function () {
  Array.prototype.forEach.call(document.querySelectorAll("details"), function (d) { d.open = true; });
  var width = window.innerWidth;
  var images = Array.prototype.slice.call(document.images);
  var loaded = images.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  var wide = Array.prototype.filter.call(document.querySelectorAll("table, figure, div.wide"), function (e) {
    return e.getBoundingClientRect().right > width + 0.5 || e.scrollWidth > e.clientWidth + 1;
  }).map(function (e) { return e.tagName + "." + e.className; });
  var sections = Array.prototype.map.call(document.querySelectorAll("h2"), function (h) { return h.id; });
  var body = document.body;
  body.setAttribute("data-images", loaded + "/" + images.length);
  body.setAttribute("data-errors", femrefErrors.join(" | "));
  body.setAttribute("data-width", document.documentElement.scrollWidth + "/" + width);
  body.setAttribute("data-overflow", wide.join(" "));
  body.setAttribute("data-sections", sections.join(" "));
});
</script>"""
BROWSER_WIDTH = 1280  # px: a laptop


def _browser(*arguments: str) -> subprocess.CompletedProcess:
    command = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--enable-logging=stderr", "--v=0",
               "--virtual-time-budget=10000", *arguments]
    return subprocess.run(command, capture_output=True, text=True, timeout=120)


@pytest.mark.skipif(_chromium() is None, reason="no headless Chromium (chromium, chromium-browser or google-chrome) on PATH; scripts/install-chromium.sh")
@pytest.mark.parametrize(
    ("name", "sections", "images"),
    [("impact", "scores models plots case", IMPACT_PLOTS), ("tolerance", "choice scores models plots case", IMPACT_PLOTS)],
)
def test_browser_renders_the_page(pages, tmp_path, name, sections, images):
    """A headless browser at 1280 px renders the page: its sections, every embedded image decoded, no console
    message or error event, nothing wider than the window (every details element opened); a screenshot is kept
    in build/ (git-ignored) for a person to look at."""
    page = pages[name]
    assert "<script" not in page
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</head>", _PROBE + "</head>"), encoding="utf-8")
    done = _browser(f"--window-size={BROWSER_WIDTH},900", "--dump-dom", probe.as_uri())
    found = {key: re.search(rf'data-{key}="([^"]*)"', done.stdout) for key in ("images", "errors", "width", "overflow", "sections")}
    assert all(found.values()), done.stderr[-2000:]
    facts = {key: match.group(1) for key, match in found.items()}
    assert facts["sections"] == sections
    assert facts["images"] == f"{images}/{images}"
    assert facts["errors"] == ""
    assert [line for line in done.stderr.splitlines() if ":CONSOLE" in line] == []
    assert facts["width"] == f"{BROWSER_WIDTH}/{BROWSER_WIDTH}" and facts["overflow"] == ""
    shown = tmp_path / "page.html"
    shown.write_text(page, encoding="utf-8")
    screenshot = tmp_path / f"report-screenshot-{name}.png"
    done = _browser(f"--window-size={BROWSER_WIDTH},2400", f"--screenshot={screenshot}", shown.as_uri())
    assert screenshot.is_file() and screenshot.read_bytes().startswith(PNG_MAGIC), done.stderr[-2000:]
    SCREENSHOTS.mkdir(exist_ok=True)
    shutil.copy(screenshot, SCREENSHOTS / ("report-screenshot.png" if name == "impact" else f"report-screenshot-{name}.png"))
