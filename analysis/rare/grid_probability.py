"""Failure probabilities under independent normal parameters, integrated over grids of runs.

The reference against which estimators are judged: a family's parameters are
independent normals (its nominal distribution); runs on a grid of parameter
values stand for the cells around them, and the probability of failing is the
nominal mass of the failing cells. Each result comes with bounds: a cell
whose neighbours disagree may hold the boundary anywhere inside it, so its
mass counts towards the low bound only if it fails and towards the high bound
in any case; the nominal mass outside the grid's box is added to the high
bound (anything out there might fail).

Three forms:

* :func:`grid_probability`: an indicator on a full grid (one axis per parameter).
* :func:`threshold_probability`: failure exactly when ``y < t(x)``, ``t`` known at
  grid points of ``x`` (when one parameter only shifts the boundary, as a lane
  width shifts a road edge); the ``y`` integral is then the normal CDF, exact,
  and a 1-D grid suffices.
* :func:`box_probability`: failure exactly inside a box whose faces were located
  by fine scans, each face known to lie within a bracket (between the last scanned
  value on one side and the first on the other): the mass is a product of normal
  CDF differences, with bounds from the brackets' ends
  (:func:`normal_interval_mass` for one side).

Plain numpy and scipy; nothing here runs a simulation.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.stats import norm


@dataclasses.dataclass(frozen=True)
class GridProbability:
    """A probability from a grid, with the bounds described in the module docstring."""

    p: float  # the nominal mass of the failing cells
    low: float  # ... less the failing cells on the boundary
    high: float  # ... plus the passing cells on the boundary and the mass outside the box
    outside_mass: float  # nominal mass outside the grid's box
    cells: int
    failing_cells: int
    boundary_cells: int

    @property
    def bound(self) -> float:
        """The largest distance from ``p`` to either bound."""
        return max(self.p - self.low, self.high - self.p)

    def to_plain(self) -> dict:
        return {**dataclasses.asdict(self), "bound": self.bound}


def cell_edges(values: np.ndarray) -> np.ndarray:
    """Edges of the cells around sorted grid values: halfway between neighbours, and
    half a step beyond the first and last value."""
    v = np.asarray(values, dtype=float)
    if v.ndim != 1 or len(v) < 2 or np.any(np.diff(v) <= 0):
        raise ValueError("grid values must be at least two, strictly increasing")
    mids = (v[1:] + v[:-1]) / 2
    return np.concatenate([[v[0] - (mids[0] - v[0])], mids, [v[-1] + (v[-1] - mids[-1])]])


def normal_cell_masses(values: np.ndarray, mean: float, sd: float) -> tuple[np.ndarray, float]:
    """The ``N(mean, sd)`` mass of each cell around ``values`` and the mass outside them."""
    cdf = norm.cdf(cell_edges(values), mean, sd)
    return np.diff(cdf), float(cdf[0] + (1.0 - cdf[-1]))


def _disagrees_with_a_neighbour(failed: np.ndarray) -> np.ndarray:
    boundary = np.zeros(failed.shape, dtype=bool)
    for axis in range(failed.ndim):
        differs = np.diff(failed, axis=axis) != 0
        lower = [slice(None)] * failed.ndim
        upper = [slice(None)] * failed.ndim
        lower[axis], upper[axis] = slice(None, -1), slice(1, None)
        boundary[tuple(lower)] |= differs
        boundary[tuple(upper)] |= differs
    return boundary


def grid_probability(failed: np.ndarray, axes: list[np.ndarray],
                     normals: list[tuple[float, float]]) -> GridProbability:
    """The nominal probability of failing from ``failed[i, j, ...]``, the outcome at
    ``(axes[0][i], axes[1][j], ...)``, each parameter ``N(mean, sd)`` from ``normals``."""
    failed = np.asarray(failed, dtype=bool)
    if failed.shape != tuple(len(a) for a in axes) or len(axes) != len(normals):
        raise ValueError(f"outcomes of shape {failed.shape} do not match the axes "
                         f"{[len(a) for a in axes]} and {len(normals)} normals")
    mass = np.ones(())
    inside = 1.0
    for values, (mean, sd) in zip(axes, normals, strict=True):
        masses, outside = normal_cell_masses(values, mean, sd)
        mass = np.multiply.outer(mass, masses)
        inside *= 1.0 - outside
    boundary = _disagrees_with_a_neighbour(failed)
    p = float(mass[failed].sum())
    return GridProbability(
        p=p, low=p - float(mass[failed & boundary].sum()),
        high=p + float(mass[~failed & boundary].sum()) + (1.0 - inside),
        outside_mass=1.0 - inside, cells=failed.size, failing_cells=int(failed.sum()),
        boundary_cells=int(boundary.sum()))


def threshold_probability(x: np.ndarray, threshold: np.ndarray, x_normal: tuple[float, float],
                          y_normal: tuple[float, float]) -> GridProbability:
    """``P(Y < t(X))`` for independent normals ``X``, ``Y``, with ``t`` known at the
    grid values ``x``. Within a cell, ``t`` is taken to lie between the least and the
    greatest of its grid value's and its neighbours' thresholds (the bounds); ``p``
    uses the cell's own. ``failing_cells`` counts the cells where ``P(Y < t)``
    exceeds 1e-15, ``boundary_cells`` those where it differs between neighbours by
    more than 1e-15 (where the bound is not nil).
    """
    x = np.asarray(x, dtype=float)
    t = np.asarray(threshold, dtype=float)
    if x.shape != t.shape:
        raise ValueError("one threshold per grid value")
    masses, outside = normal_cell_masses(x, *x_normal)
    below = norm.cdf(t, *y_normal)
    padded = np.concatenate([[below[0]], below, [below[-1]]])
    neighbours = np.stack([padded[:-2], padded[1:-1], padded[2:]])
    low, high = neighbours.min(axis=0), neighbours.max(axis=0)
    p = float(np.sum(masses * below))
    return GridProbability(
        p=p, low=float(np.sum(masses * low)), high=float(np.sum(masses * high)) + outside,
        outside_mass=outside, cells=len(x), failing_cells=int(np.sum(below > 1e-15)),
        boundary_cells=int(np.sum(high - low > 1e-15)))


#: where a boundary lies when a scan has located it: ``(lo, hi)``, the last scanned value
#: on one side and the first on the other; ``(x, x)`` when it is known exactly, and
#: ``(-inf, -inf)`` or ``(inf, inf)`` for an interval open on that side
Bracket = tuple[float, float]


@dataclasses.dataclass(frozen=True)
class BracketedProbability:
    """A probability whose region's ends are known only within brackets."""

    p: float  # every end at its bracket's midpoint
    low: float  # every end where the region is smallest
    high: float  # ... and where it is largest

    @property
    def bound(self) -> float:
        """The largest distance from ``p`` to either bound."""
        return max(self.p - self.low, self.high - self.p)

    def to_plain(self) -> dict:
        return {**dataclasses.asdict(self), "bound": self.bound}


def _checked_bracket(bracket: Bracket) -> tuple[float, float, float]:
    lo, hi = (float(v) for v in bracket)
    if not lo <= hi or ((np.isinf(lo) or np.isinf(hi)) and lo != hi):
        raise ValueError(f"a bracket is (lo, hi) with lo <= hi, both finite or the same "
                         f"infinity; got {bracket}")
    return lo, (lo + hi) / 2 if lo != hi else lo, hi


def normal_interval_mass(lower: Bracket, upper: Bracket, mean: float,
                         sd: float) -> BracketedProbability:
    """``P(a < X < b)`` for ``X ~ N(mean, sd)``, the end ``a`` somewhere in the bracket
    ``lower`` and ``b`` in ``upper``. ``low`` is the mass from ``lower``'s top to
    ``upper``'s bottom (nil if they cross), ``high`` from ``lower``'s bottom to
    ``upper``'s top."""
    a_lo, a_mid, a_hi = _checked_bracket(lower)
    b_lo, b_mid, b_hi = _checked_bracket(upper)

    def mass(a: float, b: float) -> float:
        return max(0.0, float(norm.cdf(b, mean, sd) - norm.cdf(a, mean, sd)))

    return BracketedProbability(p=mass(a_mid, b_mid), low=mass(a_hi, b_lo), high=mass(a_lo, b_hi))


def box_probability(sides: list[tuple[Bracket, Bracket]],
                    normals: list[tuple[float, float]]) -> BracketedProbability:
    """``P(a_i < X_i < b_i for every i)`` for independent ``X_i ~ N(mean_i, sd_i)``: the
    product of :func:`normal_interval_mass` over the sides ``(lower_i, upper_i)``. As
    every factor is non-negative, the products of the factors' bounds bound the product."""
    if len(sides) != len(normals) or not sides:
        raise ValueError(f"{len(sides)} sides for {len(normals)} normals")
    p = low = high = 1.0
    for (lower, upper), (mean, sd) in zip(sides, normals, strict=True):
        side = normal_interval_mass(lower, upper, mean, sd)
        p, low, high = p * side.p, low * side.low, high * side.high
    return BracketedProbability(p=p, low=low, high=high)
