"""OpenSCENARIO parameter value distributions read into samples
(scenarios/asam/xosc_distribution.py). Every file is written with scenariogeneration;
a refusal's file is one it wrote, then changed where it cannot write the fault."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from scenariogeneration import xosc

from scenarios.asam.xosc_distribution import (
    DEFAULT_SEED,
    MAX_TRIES,
    Distribution,
    read_distribution,
)
from scenarios.common.errors import FileError, SpecError
from tests.asam_samples import edited

REPO = Path(__file__).resolve().parents[1]


def write(folder: Path, distribution: xosc.Stochastic | xosc.Deterministic,
          name: str = "variation.xosc", scenario: str = "scenario.xosc") -> Path:
    """The distribution written to ``folder/name``, its ScenarioFile ``scenario`` (an
    empty file made beside it)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / scenario).parent.mkdir(parents=True, exist_ok=True)
    (folder / scenario).touch()
    path = folder / name
    xosc.ParameterValueDistribution("test", "sdc", scenario, distribution).write_xml(str(path))
    return path


def stochastic(runs: int | str, seed: float | None = 42, **distributions) -> xosc.Stochastic:
    result = xosc.Stochastic(runs, seed)
    for name, distribution in distributions.items():
        result.add_distribution(name, distribution)
    return result


def column(distribution: Distribution, name: str) -> np.ndarray:
    return np.array([sample[name] for sample in distribution.samples])


# ---- stochastic: what each distribution means ----


def test_a_normal_distributions_second_value_is_its_variance(tmp_path):
    path = write(tmp_path, stochastic(20000, 7, speed=xosc.NormalDistribution(3.0, 4.0)))
    values = column(read_distribution(path), "speed")
    assert len(values) == 20000
    assert values.mean() == pytest.approx(3.0, abs=0.08)
    # read as a standard deviation, the variance would be 16
    assert values.var() == pytest.approx(4.0, rel=0.05)


def test_a_lognormals_values_are_those_of_its_underlying_normal(tmp_path):
    """expectedValue and variance are mu and sigma^2 of ln X (a negative mu is fine)."""
    path = write(tmp_path, stochastic(20000, 7, a=xosc.LogNormalDistribution(0.5, 0.25),
                                      b=xosc.LogNormalDistribution(-1.0, 0.09)))
    read = read_distribution(path)
    a, b = column(read, "a"), column(read, "b")
    assert np.log(a).mean() == pytest.approx(0.5, abs=0.02)
    assert np.log(a).var() == pytest.approx(0.25, rel=0.05)
    assert a.mean() == pytest.approx(math.exp(0.5 + 0.25 / 2), rel=0.02)  # not 0.5
    assert (b > 0).all()
    assert np.log(b).mean() == pytest.approx(-1.0, abs=0.02)


def test_a_range_truncates_by_drawing_again_not_by_clipping(tmp_path):
    path = write(tmp_path, stochastic(20000, 3, x=xosc.NormalDistribution(
        0.0, 1.0, xosc.Range(-0.5, 1.0))))
    values = column(read_distribution(path), "x")
    assert values.min() >= -0.5 and values.max() <= 1.0
    assert not np.isin(values, [-0.5, 1.0]).any()  # clipping would pile a third on the ends
    phi = lambda z: math.exp(-z * z / 2) / math.sqrt(2 * math.pi)  # noqa: E731
    cdf = lambda z: 0.5 * (1 + math.erf(z / math.sqrt(2)))  # noqa: E731
    truncated_mean = (phi(-0.5) - phi(1.0)) / (cdf(1.0) - cdf(-0.5))
    assert values.mean() == pytest.approx(truncated_mean, abs=0.01)


def test_poisson_mean_and_its_range(tmp_path):
    path = write(tmp_path, stochastic(20000, 5, n=xosc.PoissonDistribution(3.5),
                                      m=xosc.PoissonDistribution(3.5, xosc.Range(2, 5))))
    read = read_distribution(path)
    n, m = column(read, "n"), column(read, "m")
    assert n.mean() == pytest.approx(3.5, abs=0.06)
    assert n.var() == pytest.approx(3.5, rel=0.05)
    assert (n == np.round(n)).all()
    assert set(m) <= {2.0, 3.0, 4.0, 5.0}


def test_uniform_stays_inside_its_range(tmp_path):
    path = write(tmp_path, stochastic(5000, 1, u=xosc.UniformDistribution(xosc.Range(2, 4))))
    values = column(read_distribution(path), "u")
    assert values.min() >= 2 and values.max() <= 4
    assert values.mean() == pytest.approx(3.0, abs=0.05)


def test_a_histogram_picks_bins_by_weight_and_draws_uniform_inside(tmp_path):
    histogram = (xosc.Histogram().add_bin(1, xosc.Range(0, 1)).add_bin(3, xosc.Range(1, 2))
                 .add_bin(0, xosc.Range(5, 10)))
    values = column(read_distribution(write(tmp_path, stochastic(20000, 9, gap=histogram))),
                    "gap")
    assert values.min() >= 0 and values.max() <= 2  # the weightless bin is never picked
    assert (values < 1).mean() == pytest.approx(0.25, abs=0.015)
    upper = values[values >= 1]
    assert upper.mean() == pytest.approx(1.5, abs=0.02)


def test_a_probability_set_picks_values_by_weight_typed(tmp_path):
    choices = (xosc.ProbabilityDistributionSet().add_set("car", 1).add_set("truck", 2)
               .add_set("30", 1))
    values = [s["kind"] for s in read_distribution(
        write(tmp_path, stochastic(20000, 9, kind=choices))).samples]
    assert set(values) == {"car", "truck", 30.0}
    assert values.count("truck") / len(values) == pytest.approx(0.5, abs=0.015)
    assert values.count(30.0) / len(values) == pytest.approx(0.25, abs=0.015)


# ---- stochastic: counts, seeds, the order of draws ----


def test_the_draws_are_run_by_run_parameter_by_parameter_from_the_seed(tmp_path):
    path = write(tmp_path, stochastic(6, 123, **{"$speed": xosc.NormalDistribution(10, 4),
                                                 "gap": xosc.UniformDistribution(
                                                     xosc.Range(0, 1))}))
    read = read_distribution(path)
    assert (read.kind, read.seed, read.parameters) == ("stochastic", 123, ("speed", "gap"))
    rng = np.random.default_rng(123)
    expected = []
    for _ in range(6):
        expected.append({"speed": rng.normal(10, 2), "gap": rng.uniform(0, 1)})
    assert list(read.samples) == expected
    assert read.path == path and read.scenario_file == tmp_path / "scenario.xosc"


def test_the_same_seed_gives_the_same_samples_and_another_seed_others(tmp_path):
    normal = xosc.NormalDistribution(0, 1)
    one = read_distribution(write(tmp_path / "a", stochastic(50, 42, x=normal)))
    again = read_distribution(write(tmp_path / "b", stochastic(50, 42.0, x=normal)))
    other = read_distribution(write(tmp_path / "c", stochastic(50, 43, x=normal)))
    assert one.samples == again.samples and again.seed == 42
    assert one.samples != other.samples
    fewer = read_distribution(write(tmp_path / "d", stochastic(20, 42, x=normal)))
    assert fewer.samples == one.samples[:20]  # more runs add runs, never change the first


def test_without_a_seed_the_default_seed_draws(tmp_path):
    normal = xosc.NormalDistribution(0, 1)
    unseeded = read_distribution(write(tmp_path / "a", stochastic(30, None, x=normal)))
    seeded = read_distribution(write(tmp_path / "b", stochastic(30, DEFAULT_SEED, x=normal)))
    assert unseeded.seed is None
    assert unseeded.samples == seeded.samples


def test_another_process_reads_the_same_samples(tmp_path):
    path = write(tmp_path, stochastic(40, 11, x=xosc.NormalDistribution(1, 2),
                                      k=xosc.ProbabilityDistributionSet().add_set("a", 1)
                                      .add_set("b", 1)))
    script = ("import json, sys; from scenarios.asam.xosc_distribution import read_distribution;"
              " print(json.dumps(read_distribution(sys.argv[1]).samples))")
    out = subprocess.run([sys.executable, "-c", script, str(path)], cwd=REPO, check=True,
                         capture_output=True, text=True).stdout
    assert [tuple(s.items()) for s in json.loads(out)] == \
        [tuple(s.items()) for s in read_distribution(path).samples]


# ---- deterministic ----


def ranged(step: float, lower: float, upper: float) -> xosc.DistributionRange:
    return xosc.DistributionRange(step, xosc.Range(lower, upper))


def valued(*values: str) -> xosc.DistributionSet:
    result = xosc.DistributionSet()
    for value in values:
        result.add_value(value)
    return result


def deterministic(**singles) -> xosc.Deterministic:
    result = xosc.Deterministic()
    for name, distribution in singles.items():
        result.add_single_distribution(name, distribution)
    return result


@pytest.mark.parametrize(("step", "lower", "upper", "expected"), [
    (0.1, 0.1, 0.3, [0.1, 0.2, 0.3]),  # float steps would lose the upper end
    (0.3, 0.0, 1.0, [0.0, 0.3, 0.6, 0.9]),  # an upper end off the grid is not a value
    (0.1, 0.0, 1.0, [round(i * 0.1, 10) for i in range(11)]),
    (10, 10, 80, [10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0]),
    (5, 7, 7, [7.0]),
])
def test_a_distribution_range_includes_both_ends_on_its_grid(tmp_path, step, lower, upper,
                                                              expected):
    read = read_distribution(write(tmp_path, deterministic(x=ranged(step, lower, upper))))
    assert [s["x"] for s in read.samples] == expected
    assert (read.kind, read.seed) == ("deterministic", None)


def test_an_ncap_style_variation_is_the_product_of_its_parameters(tmp_path):
    """As the public Euro NCAP sets: bare names, a speed range with a step, sets."""
    variation = deterministic(VUT_Speed=ranged(5, 10, 80),
                              Overlap=valued("-50", "-25", "0", "25", "50"),
                              Target_Type=valued("GVT", "EMT"))
    path = write(tmp_path / "variations", variation, name="CCRs.xosc",
                 scenario="../scenarios/CCRs.xosc")
    read = read_distribution(path)
    assert read.parameters == ("VUT_Speed", "Overlap", "Target_Type")
    assert len(read.samples) == 15 * 5 * 2
    assert read.samples[0] == {"VUT_Speed": 10.0, "Overlap": -50.0, "Target_Type": "GVT"}
    assert read.samples[1] == {"VUT_Speed": 10.0, "Overlap": -50.0, "Target_Type": "EMT"}
    assert read.samples[-1] == {"VUT_Speed": 80.0, "Overlap": 50.0, "Target_Type": "EMT"}
    combos = {tuple(s.values()) for s in read.samples}
    assert len(combos) == len(read.samples)
    assert read.scenario_file.resolve() == (tmp_path / "scenarios" / "CCRs.xosc").resolve()


def test_multi_parameter_sets_stay_joint_and_multiply_the_singles(tmp_path):
    variation = deterministic(**{"$VUT_Speed": valued("50", "80")})
    pairs = xosc.DeterministicMultiParameterDistribution()
    for headway, decel in (("12", "-2"), ("40", "-2"), ("12", "-6")):
        pairs.add_value_set(xosc.ParameterValueSet().add_parameter("$Headway", headway)
                            .add_parameter("Target_Decel", decel))
    variation.add_multi_distribution(pairs)  # scenariogeneration writes it first
    read = read_distribution(write(tmp_path, variation))
    assert read.parameters == ("VUT_Speed", "Headway", "Target_Decel")
    assert len(read.samples) == 2 * 3
    assert [(s["Headway"], s["Target_Decel"]) for s in read.samples[:3]] == \
        [(12.0, -2.0), (40.0, -2.0), (12.0, -6.0)]
    assert [s["VUT_Speed"] for s in read.samples] == [50.0] * 3 + [80.0] * 3


# ---- refusals: each names its element and the file ----


def changed(path: Path, old: str, new: str) -> Path:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    return path


def drop_scenario_file(root: ET.Element) -> None:
    pvd = root.find("ParameterValueDistribution")
    pvd.remove(pvd.find("ScenarioFile"))


def user_defined(root: ET.Element) -> None:
    holder = root.find(".//StochasticDistribution")
    holder.remove(holder[0])
    ET.SubElement(holder, "UserDefinedDistribution", type="mine").text = "1 2 3"


def normal(tmp_path: Path, *args, **kwargs) -> Path:
    return write(tmp_path, stochastic(10, 1, x=xosc.NormalDistribution(*args, **kwargs)))


def two_sets(tmp_path: Path) -> Path:
    sets = xosc.DeterministicMultiParameterDistribution()
    sets.add_value_set(xosc.ParameterValueSet().add_parameter("a", "1").add_parameter("b", "2"))
    sets.add_value_set(xosc.ParameterValueSet().add_parameter("a", "3"))
    return write(tmp_path, xosc.Deterministic().add_multi_distribution(sets))


def plain_scenario(tmp_path: Path) -> Path:
    path = tmp_path / "plain.xosc"
    xosc.Scenario("plain", "sdc", xosc.ParameterDeclarations(), xosc.Entities(),
                  xosc.StoryBoard(xosc.Init()), xosc.RoadNetwork(), xosc.Catalog()
                  ).write_xml(str(path))
    return path


REFUSALS = {
    "lower above upper": (lambda t: write(t, stochastic(5, 1, x=xosc.UniformDistribution(
        xosc.Range(5, 1)))), "UniformDistribution/Range", "lowerLimit"),
    "no test runs": (lambda t: write(t, stochastic(0, 1, x=xosc.NormalDistribution(0, 1))),
                     "Stochastic", "numberOfTestRuns"),
    "fractional test runs": (lambda t: write(t, stochastic("2.5", 1, x=xosc.NormalDistribution(
        0, 1))), "Stochastic", "numberOfTestRuns"),
    "fractional seed": (lambda t: write(t, stochastic(5, 1.5, x=xosc.NormalDistribution(0, 1))),
                        "Stochastic", "randomSeed"),
    "misspelt seed": (lambda t: changed(normal(t, 0, 1), "randomSeed=", "randomseed="),
                      "Stochastic", "randomseed"),
    "unknown distribution": (lambda t: changed(normal(t, 0, 1), "<NormalDistribution ",
                                               "<TriangularDistribution "),
                             "StochasticDistribution[x]", "TriangularDistribution"),
    "user-defined distribution": (lambda t: edited(normal(t, 0, 1), user_defined),
                                  "UserDefinedDistribution", "mine"),
    "negative variance": (lambda t: normal(t, 0, -1), "NormalDistribution", "variance"),
    "parameter reference": (lambda t: normal(t, 0, 1, xosc.Range("$low", 5)),
                            "NormalDistribution/Range", "$low"),
    "range without mass": (lambda t: normal(t, 0, 1, xosc.Range(50, 60)),
                           "NormalDistribution/Range", str(MAX_TRIES)),
    "weightless histogram": (lambda t: write(t, stochastic(5, 1, x=xosc.Histogram().add_bin(
        0, xosc.Range(0, 1)))), "Histogram", "weights"),
    "no scenario file element": (lambda t: edited(normal(t, 0, 1), drop_scenario_file),
                                 "ParameterValueDistribution", "ScenarioFile"),
    "scenario file missing": (lambda t: changed(normal(t, 0, 1), 'filepath="scenario.xosc"',
                                                'filepath="elsewhere.xosc"'),
                              "ScenarioFile", "elsewhere.xosc"),
    "a plain scenario": (plain_scenario, "OpenSCENARIO", "ParameterValueDistribution"),
    "version 1.0": (lambda t: changed(normal(t, 0, 1), 'revMinor="3"', 'revMinor="0"'),
                    "FileHeader", "1.0"),
    "zero step": (lambda t: write(t, deterministic(x=ranged(0, 0, 1))), "DistributionRange",
                  "stepWidth"),
    "a parameter twice": (lambda t: write(t, deterministic(**{"$x": valued("1"),
                                                              "x": valued("2")})),
                          "DeterministicSingleParameterDistribution", "'x'"),
    "sets of other parameters": (two_sets, "ParameterValueSet[1]", "same parameters"),
}


@pytest.mark.parametrize("case", REFUSALS)
def test_a_refusal_names_its_element_and_its_file(tmp_path, case):
    make, element, detail = REFUSALS[case]
    path = make(tmp_path)
    with pytest.raises(SpecError) as caught:
        read_distribution(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: ")
    assert caught.value.file == str(path)
    assert element in caught.value.field, message
    assert detail in message


def test_malformed_xml_is_refused_naming_the_file(tmp_path):
    path = normal(tmp_path, 0, 1)
    path.write_bytes(path.read_bytes()[:-40])  # cut short
    with pytest.raises(FileError, match="not well-formed XML") as caught:
        read_distribution(path)
    assert str(caught.value).startswith(f"{path}: ")


def test_a_missing_distribution_file_is_refused(tmp_path):
    with pytest.raises(FileError, match="no such file"):
        read_distribution(tmp_path / "nowhere.xosc")
