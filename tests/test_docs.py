"""The manual cannot drift from the code: it builds with warnings as errors, its
generated reference lists exactly what the code defines, the README stays a front
door (at most 200 lines, links that resolve), and the tutorial's commands run as
written (docs/development.md, "The manual")."""

from __future__ import annotations

import dataclasses
import html
import importlib.util
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree

import pytest

from scenarios.spec import controller_params, controller_spec, sweep_spec
from scenarios.sumo_net.build import sumo_binary
from sdc.cli import main as cli_main
from sdc.run import result_row

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
TUTORIAL = ROOT / "docs" / "tutorial.md"
README_MAX_LINES = 200
#: what a tutorial block may take at most [s] (the sweep of 20 runs takes about 30 s)
BLOCK_TIMEOUT_S = 300


def _generator():
    """docs/gen_reference.py, imported from its path (docs/ is no package)."""
    spec = importlib.util.spec_from_file_location("gen_reference", ROOT / "docs" /
                                                  "gen_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The manual built as `make docs` builds it (`mkdocs build --strict`), into a
    scratch directory."""
    out = tmp_path_factory.mktemp("site")
    built = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
         str(ROOT / "mkdocs.yml"), "--site-dir", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert built.returncode == 0, f"mkdocs build --strict failed:\n{built.stderr}"
    assert "WARNING" not in built.stderr, built.stderr
    return out


def _cells(page: str) -> list[list[str]]:
    """Each table row of an HTML page, its cells as plain text."""
    rows = []
    for row in re.findall(r"<tr>(.*?)</tr>", page, re.S):
        cells = re.findall(r"<td[^>]*>(.*?)</td>", row, re.S)
        if cells:
            rows.append([html.unescape(re.sub(r"<[^>]+>", "", c)).strip() for c in cells])
    return rows


def test_the_manual_builds_with_warnings_as_errors(site):
    for page in ("index.html", "tutorial.html", "reference/results.html", "reference/spec.html",
                 "reference/cli.html", "reference/controller-api.html", "architecture.html",
                 "images/report.png"):
        assert (site / page).is_file(), page


def test_the_reference_lists_exactly_the_result_columns_result_row_defines(site):
    page = (site / "reference" / "results.html").read_text()
    columns_part = page.split('id="trace-columns"')[0]
    rows = _cells(columns_part)
    defined = [*result_row.COLUMNS, *result_row.ADAPTIVE_COLUMNS]
    assert [r[0] for r in rows] == [c.name for c in defined] + [
        result_row.PARAM_PREFIX + "<path>"]
    for row, column in zip(rows, defined, strict=False):
        assert row[1] == str(column.arrow_type), column.name
        assert " ".join(row[4].split()) == " ".join(column.meaning.split()), column.name
    assert _generator().result_columns() == [c.name for c in defined]


def test_the_reference_lists_every_spec_field_api_field_and_command_option(site):
    spec_page = (site / "reference" / "spec.html").read_text()
    listed = {r[0] for r in _cells(spec_page)}
    generator = _generator()
    classes = [cls for _, cls, _, _ in generator.scenario_tables()
               if cls is not controller_spec.ControllerSpec]
    classes += [*controller_params.CONTROLLER_PARAMS.values(), sweep_spec._SweepTable]
    for cls in classes:
        for field in dataclasses.fields(cls):
            if field.name != "params":  # the sweep's [sweep.params], a table of its own
                assert field.name in listed, f"{cls.__name__}.{field.name}"
    for kind in ("uniform", "loguniform", "normal", "int_range", "choice"):
        assert kind in listed

    api_listed = {r[0] for r in _cells((site / "reference" / "controller-api.html").read_text())}
    for cls in generator.api_classes():
        for name, _, _ in generator.api_fields(cls):
            assert name in api_listed, f"{cls.__name__}.{name}"

    cli_page = html.unescape((site / "reference" / "cli.html").read_text())
    for name in cli_main.commands:
        assert f"$ sdc {name} --help" in cli_page, name
        for option in generator.options(name):
            assert option in cli_page.split(f"$ sdc {name} --help")[1], f"sdc {name} {option}"


def _links(markdown: str) -> list[str]:
    return re.findall(r"\]\(([^)\s]+)\)", markdown)


def test_the_readme_is_a_front_door_whose_links_resolve():
    text = README.read_text()
    assert len(text.splitlines()) <= README_MAX_LINES
    links = _links(text)
    assert links, "the README links into the manual"
    for link in links:
        if re.match(r"^[a-z]+:", link):  # http:, https:, mailto:
            continue
        target = (ROOT / link.split("#")[0]).resolve()
        assert target.exists(), f"README links to {link}, which does not exist"
    blocks = re.findall(r"```sh\n(.*?)```", text, re.S)
    assert any(re.match(r"make test\b", line) for b in blocks for line in b.splitlines()), \
        "CI runs the test command the README gives: `make test` in a sh block"
    for block in blocks:  # the quick start names files that exist
        for path in re.findall(r"\b((?:scenarios|examples)/\S+?\.(?:toml|py))\b", block):
            assert (ROOT / path).is_file(), path


def tutorial_blocks() -> list[str]:
    """The tutorial's shell blocks (```sh), in order: the commands it tells to run."""
    return re.findall(r"^```sh\n(.*?)^```", TUTORIAL.read_text(), re.S | re.M)


def tutorial_command(program: str) -> list[str]:
    """The tutorial's command line that runs ``program`` (``.venv/bin/<program>``), its
    continued lines joined, split into words as the shell does."""
    lines = "\n".join(tutorial_blocks()).replace("\\\n", " ").splitlines()
    (line,) = [line for line in lines if line.startswith(f".venv/bin/{program} ")]
    return shlex.split(line)


def test_the_tutorials_town_has_the_sidewalks_and_crossings_it_says(tmp_path):
    """The tutorial's netgenerate line, run as written: its network has sidewalks (lanes
    that allow pedestrians) and crossings, as the text says. netgenerate guesses them on
    streets of 13.89 m/s at most only; 13.9 made none, silently."""
    words = tutorial_command("netgenerate")
    out = words.index("--output-file") + 1
    words[out] = str(tmp_path / Path(words[out]).name)
    subprocess.run([sumo_binary("netgenerate"), *words[1:]], check=True, capture_output=True)
    net = ElementTree.parse(words[out]).getroot()
    sidewalks = [lane for edge in net.iter("edge") if edge.get("function") is None
                 for lane in edge.iter("lane") if lane.get("allow") == "pedestrian"]
    crossings = [edge for edge in net.iter("edge") if edge.get("function") == "crossing"]
    assert sidewalks and crossings, (len(sidewalks), len(crossings))
    assert "sidewalks" in TUTORIAL.read_text() and "crossings" in TUTORIAL.read_text()


def test_every_how_to_is_linked_from_the_readme_the_home_page_and_the_nav():
    nav = (ROOT / "mkdocs.yml").read_text()
    home = (ROOT / "docs" / "index.md").read_text()
    for page in sorted((ROOT / "docs" / "how-to").glob("*.md")):
        assert f"(docs/how-to/{page.name})" in README.read_text(), page.name
        assert f"(how-to/{page.name})" in home, page.name
        assert f" how-to/{page.name}" in nav, page.name


@pytest.mark.slow
def test_the_tutorial_runs_as_written(tmp_path):
    """Every sh block of docs/tutorial.md, in order, in a scratch copy of the
    repository's root (the venv, the catalog and the examples linked in), as a
    reader runs them; the outcomes the text claims are checked too."""
    (tmp_path / ".venv").symlink_to(Path(sys.prefix))
    for name in ("scenarios", "examples"):
        (tmp_path / name).symlink_to(ROOT / name)
    outputs = {}
    for block in tutorial_blocks():
        done = subprocess.run(["bash", "-euo", "pipefail", "-c", block], cwd=tmp_path,
                              capture_output=True, text=True, timeout=BLOCK_TIMEOUT_S)
        assert done.returncode == 0, (f"the tutorial's block\n{block}\nexited "
                                      f"{done.returncode}:\n{done.stdout}\n{done.stderr}")
        outputs[block] = done.stdout + done.stderr

    def output_of(command: str) -> str:
        return next(out for block, out in outputs.items() if command in block)

    careful = output_of("sdc run mine/town.toml --controller mine/careful.py:Careful")
    assert "outcome:   stuck (no collision)" in careful  # it stops behind the car
    gate = output_of("sdc report runs/town")
    assert "gate FAILED: avoid: " in gate and "; Careful: " in gate
    assert "completed as few as 0.0%" in gate  # Careful completes none
    assert output_of("--verify").count("identical") >= 1
    for made in ("runs/demo/report.html", "mine/town.net.xml", "runs/town/results.parquet",
                 "runs/town.xml", "runs/careful.html", "runs/avoid.png",
                 "runs/town-settling.png"):
        assert (tmp_path / made).is_file(), made
