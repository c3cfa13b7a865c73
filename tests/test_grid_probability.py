"""analysis.rare.grid_probability against probabilities known in closed form."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from analysis.rare.grid_probability import (
    box_probability,
    cell_edges,
    grid_probability,
    normal_cell_masses,
    normal_interval_mass,
    threshold_probability,
)


def test_cells_meet_halfway_and_reach_half_a_step_beyond_the_ends():
    assert cell_edges(np.array([0.0, 1.0, 3.0])) == pytest.approx([-0.5, 0.5, 2.0, 4.0])
    with pytest.raises(ValueError):
        cell_edges(np.array([1.0, 1.0]))


def test_cell_masses_and_the_mass_outside_make_one():
    masses, outside = normal_cell_masses(np.linspace(-3, 3, 61), 0.0, 1.0)
    assert masses.sum() + outside == pytest.approx(1.0)
    assert outside == pytest.approx(2 * norm.sf(3.05))


def test_a_half_plane_on_a_grid_is_bracketed_by_its_bounds():
    """Failure when x + y > 4 under N(0, 1) x N(0, 1): P = sf(4 / sqrt(2))."""
    axis = np.linspace(-6, 6, 241)
    failed = np.add.outer(axis, axis) > 4.0
    result = grid_probability(failed, [axis, axis], [(0.0, 1.0), (0.0, 1.0)])
    exact = norm.sf(4 / np.sqrt(2))
    assert result.low <= exact <= result.high
    assert result.p == pytest.approx(exact, rel=0.05)
    assert result.boundary_cells > 0 and result.failing_cells == failed.sum()


def test_grid_probability_refuses_mismatched_axes():
    with pytest.raises(ValueError):
        grid_probability(np.zeros((3, 4), bool), [np.arange(3.0), np.arange(3.0)],
                         [(0, 1), (0, 1)])


def test_a_threshold_linear_in_x_gives_the_exact_probability_within_its_bounds():
    """P(Y < 0.5 X - 1.5) for X ~ N(1, 0.5), Y ~ N(0, 0.2): Y - 0.5 X ~ N(-0.5, sqrt(0.1025))."""
    x = np.linspace(1 - 6 * 0.5, 1 + 6 * 0.5, 601)
    result = threshold_probability(x, 0.5 * x - 1.5, (1.0, 0.5), (0.0, 0.2))
    exact = norm.cdf(-1.5, -0.5, np.sqrt(0.25 * 0.25 + 0.04))
    assert result.low <= exact <= result.high
    assert result.p == pytest.approx(exact, rel=1e-3)
    assert result.bound < 0.1 * exact


def test_an_interval_with_exact_ends_is_the_cdf_difference():
    result = normal_interval_mass((-1.0, -1.0), (2.0, 2.0), 0.5, 2.0)
    exact = norm.cdf(2.0, 0.5, 2.0) - norm.cdf(-1.0, 0.5, 2.0)
    assert result.p == result.low == result.high == pytest.approx(exact)
    assert result.bound == pytest.approx(0.0)


def test_bracketed_ends_bound_the_interval_and_open_ends_reach_infinity():
    """The tail X > 3 of N(0, 1), its end known to lie in (2.99, 3.01)."""
    result = normal_interval_mass((2.99, 3.01), (np.inf, np.inf), 0.0, 1.0)
    assert result.low == pytest.approx(norm.sf(3.01))
    assert result.high == pytest.approx(norm.sf(2.99))
    assert result.p == pytest.approx(norm.sf(3.0))
    assert result.low <= norm.sf(3.0) <= result.high
    # brackets that cross leave nothing certain
    assert normal_interval_mass((0.0, 1.0), (0.5, 0.6), 0.0, 1.0).low == 0.0


def test_a_bracket_must_be_ordered_and_not_half_infinite():
    for bad in ((1.0, 0.0), (-np.inf, 0.0), (0.0, np.inf), (np.nan, 1.0)):
        with pytest.raises(ValueError):
            normal_interval_mass(bad, (np.inf, np.inf), 0.0, 1.0)


def test_a_box_is_the_product_of_its_sides():
    """X > 2 and |Y| < 1 under N(0, 1) x N(0, 0.5), each face bracketed by 0.01."""
    box = box_probability([((1.995, 2.005), (np.inf, np.inf)),
                           ((-1.005, -0.995), (0.995, 1.005))], [(0.0, 1.0), (0.0, 0.5)])
    exact = norm.sf(2.0) * (norm.cdf(1.0, 0, 0.5) - norm.cdf(-1.0, 0, 0.5))
    assert box.low <= exact <= box.high
    assert box.p == pytest.approx(exact, rel=1e-3)
    assert box.low == pytest.approx(norm.sf(2.005) * (norm.cdf(0.995, 0, 0.5)
                                                      - norm.cdf(-0.995, 0, 0.5)))
    assert box.to_plain()["bound"] == box.bound
    with pytest.raises(ValueError):
        box_probability([((0.0, 0.0), (1.0, 1.0))], [(0.0, 1.0), (0.0, 1.0)])
