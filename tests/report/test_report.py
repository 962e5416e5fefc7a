"""``femref report``: a self-contained, well-formed HTML page of a result file, or exit 2.

Small scenes (8 FEM elements, short ends) are run through the runner and the result
writer, as ``femref run`` does, once per module; each page is checked for balanced tags,
the score values of the file, PNG data-URI images (one per expected plot) and, where a
headless Chromium exists, that a browser loads every image.
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
        {**_case_data(impact), "fem": {"elements": 8, "order": 2}, "models": ["fem", "rigid"]},
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
    }


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
    """Impact: one coupler plot, one plot per sensor, network estimators and the failed model shown."""
    page = pages["impact"]
    _assert_pngs(_images(page), 1 + IMPACT_SENSORS)
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


def _chromium() -> str | None:
    return next((p for name in ("chromium", "chromium-browser", "google-chrome") if (p := shutil.which(name))), None)


_COUNT_IMAGES = """<script>
window.addEventListener("load", function () {
  var images = Array.prototype.slice.call(document.images);
  var loaded = images.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.body.setAttribute("data-images", loaded + "/" + images.length);
});
</script>"""


@pytest.mark.skipif(_chromium() is None, reason="no headless Chromium (chromium, chromium-browser or google-chrome) on PATH")
def test_browser_loads_every_image(pages, tmp_path):
    """A headless browser decodes every embedded image (the page itself carries no script)."""
    page = pages["impact"]
    assert "<script" not in page
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", _COUNT_IMAGES + "</body>"), encoding="utf-8")
    command = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=10000", "--dump-dom", probe.as_uri()]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    found = re.search(r'data-images="(\d+)/(\d+)"', done.stdout)
    assert found, done.stderr[-2000:]
    loaded, total = map(int, found.groups())
    assert total == 1 + IMPACT_SENSORS and loaded == total
