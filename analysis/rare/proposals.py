"""The space and the proposals of the rare-event samplers (:mod:`analysis.rare.rare_events`,
:mod:`analysis.rare.mode_search`): standard-normal points and the unit cube, the
nominal density, Gaussian kernel mixtures and their fit to weighted elites, the
defensive mixtures runs are drawn from, importance weights and what they are worth.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
from scipy import special

_LOG_2PI = math.log(2.0 * math.pi)
_BELOW_ONE = float(np.nextafter(1.0, 0.0))
#: float64 elements per chunk of kernel distances: 2 MB stay in the cache (a third faster
#: than 32 MB on the bank); the result does not depend on it, each row is its own
_CHUNK_ELEMENTS = 262_144
#: kernels whose weight is below this share of the largest are dropped from a fit
_NEGLIGIBLE_MIX = 1e-6


# --- the space ----------------------------------------------------------------------------

def unit_points(z: np.ndarray) -> np.ndarray:
    """``u = Phi(z)`` clipped into [0, 1): the sweep's unit-cube coordinates of a batch.

    Beyond ``|z| ~ 8.3`` ``Phi`` rounds to 1 in double precision, so such a
    coordinate becomes the largest double below 1 (the top of the parameter's
    range) rather than 1, which ``Param.at`` does not take.
    """
    return np.clip(special.ndtr(np.asarray(z, dtype=float)), 0.0, _BELOW_ONE)


def nominal_log_density(z: np.ndarray) -> np.ndarray:
    """Log density of ``N(0, I)`` at each row of ``z`` (n, d)."""
    z = np.atleast_2d(z)
    return -0.5 * (np.sum(z * z, axis=1) + z.shape[1] * _LOG_2PI)


def weights_from_log_densities(log_nominal: np.ndarray, log_proposal: np.ndarray) -> np.ndarray:
    """Importance weights ``nominal / proposal``, formed in log space (no 0/0, no overflow
    until the ratio itself is out of range)."""
    return np.exp(np.asarray(log_nominal, dtype=float) - np.asarray(log_proposal, dtype=float))


# --- the proposal -------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class KernelMixture:
    """``sum_k mix_k N(centres_k, cov)``: Gaussian kernels sharing one covariance.

    A kernel density estimate of where the elites of a level lie (one kernel per
    point, :func:`kernel_mixture_fit`), or a single Gaussian (one centre).
    """

    centres: np.ndarray  # (m, d)
    mix: np.ndarray  # (m,), sums to 1
    cov: np.ndarray  # (d, d)

    @property
    def dims(self) -> int:
        return self.centres.shape[1]

    def sample(self, count: int, rng: np.random.Generator) -> np.ndarray:
        which = rng.choice(self.mix.size, size=count, p=self.mix)
        return self.centres[which] + rng.standard_normal((count, self.dims)) @ self._chol.T

    @functools.cached_property
    def _chol(self) -> np.ndarray:
        return np.linalg.cholesky(self.cov)

    @functools.cached_property
    def _white_centres(self) -> np.ndarray:
        return np.linalg.solve(self._chol, self.centres.T).T

    def log_density(self, z: np.ndarray) -> np.ndarray:
        z = np.atleast_2d(z)
        chol, white_c = self._chol, self._white_centres
        white_z = np.linalg.solve(chol, z.T).T
        log_norm = np.sum(np.log(np.diag(chol))) + 0.5 * self.dims * _LOG_2PI
        log_mix = np.log(self.mix)
        # per dimension, (n, m) at a time: a sum over the short last axis of an (n, m, d)
        # array costs a reduction call per kernel and point
        z_columns = [np.ascontiguousarray(white_z[:, k, None]) for k in range(self.dims)]
        c_columns = [np.ascontiguousarray(white_c[None, :, k]) for k in range(self.dims)]
        out = np.empty(z.shape[0])
        rows = max(1, _CHUNK_ELEMENTS // max(1, self.mix.size * self.dims))
        for start in range(0, z.shape[0], rows):
            if min(rows, z.shape[0] - start) * self.mix.size == 1:  # one distance: summed inside
                diff = white_z[start:start + rows, None, :] - white_c[None, :, :]
                log_terms = log_mix - 0.5 * np.sum(diff * diff, axis=2)
            else:
                log_terms = _sum_of_squares(z_columns, c_columns, start, rows)
                log_terms *= -0.5
                log_terms = np.add(log_mix, log_terms, out=log_terms)
            out[start:start + rows] = _logsumexp(log_terms, axis=1)
        return out - log_norm


def _sum_of_squares(z_columns: list[np.ndarray], c_columns: list[np.ndarray],
                    start: int, rows: int) -> np.ndarray:
    """``np.sum(diff * diff, axis=2)`` of the rows' kernel distances ``diff`` (n, m, d), to
    the bit: ``diff`` keeps the layout of the whitened points and centres
    (``solve(...).T``, column-major), so its last axis has the largest stride and NumPy
    adds the squares one dimension at a time, in order, ``((s0 + s1) + s2) + ...``; a
    single distance has no such layout and is summed pairwise, hence the caller's own
    branch for it (tests/test_rare_events.py holds both to the bit)."""
    total = None
    for z_k, c_k in zip(z_columns, c_columns, strict=True):
        diff = np.subtract(z_k[start:start + rows], c_k)
        diff *= diff
        if total is None:
            total = diff
        else:
            total += diff
    return total


def _logsumexp(a: np.ndarray, axis: int) -> np.ndarray:
    """``scipy.special.logsumexp(a, axis=axis)`` of a real array to the bit, the same
    operations without its generic overhead (ten times the arithmetic on the bank's
    arrays); where any result is not finite, scipy's own."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # as scipy's
        a_max = np.max(a, axis=axis, keepdims=True)
        at_max = a == a_max
        count = np.sum(at_max, axis=axis, keepdims=True, dtype=a.dtype)
        terms = np.subtract(a, a_max)
        np.exp(terms, out=terms)
        np.putmask(terms, at_max, 0.0)  # the maxima are counted in ``count``, not summed
        s = np.sum(terms, axis=axis, keepdims=True)
        s = np.where(s == 0, s, s / count)
        out = np.squeeze(np.log1p(s) + np.log(count) + a_max, axis=axis)
    if not np.all(np.isfinite(out)):
        return special.logsumexp(a, axis=axis)
    return out


def gaussian(mean: np.ndarray, cov: np.ndarray) -> KernelMixture:
    """``N(mean, cov)`` as a one-kernel :class:`KernelMixture`."""
    mean = np.asarray(mean, dtype=float)
    return KernelMixture(mean[None, :], np.ones(1), np.asarray(cov, dtype=float))


def standard_normal(dims: int) -> KernelMixture:
    return gaussian(np.zeros(dims), np.eye(dims))


@dataclasses.dataclass(frozen=True)
class Proposal:
    """The sampling density ``q = alpha N(0, I) + (1 - alpha) sum_j share_j part_j``.

    ``defensive_fraction`` alpha keeps ``q >= alpha * nominal`` everywhere, so
    every weight is at most ``1 / alpha``: a region the parts missed costs
    variance but cannot produce one huge weight that dominates (and breaks the
    normal interval of) the estimate. It also bounds p when no failure is seen
    (see :func:`estimate_from_rows`).
    """

    parts: tuple[KernelMixture, ...]
    shares: tuple[float, ...]  # sum to 1
    defensive_fraction: float = 0.0

    @property
    def dims(self) -> int:
        return self.parts[0].dims

    @property
    def max_weight(self) -> float:
        """An upper bound of ``nominal / proposal`` over the whole space (inf without mixture)."""
        return 1.0 / self.defensive_fraction if self.defensive_fraction > 0 else math.inf

    def _components(self) -> tuple[list[KernelMixture], np.ndarray]:
        alpha = self.defensive_fraction
        parts = [standard_normal(self.dims), *self.parts]
        return parts, np.array([alpha, *((1.0 - alpha) * np.array(self.shares))])

    def sample(self, count: int, rng: np.random.Generator) -> np.ndarray:
        parts, shares = self._components()
        which = rng.choice(len(parts), size=count, p=shares / shares.sum())
        z = np.empty((count, self.dims))
        for index, part in enumerate(parts):
            chosen = which == index
            if chosen.any():
                z[chosen] = part.sample(int(chosen.sum()), rng)
        return z

    def log_density(self, z: np.ndarray) -> np.ndarray:
        parts, shares = self._components()
        used = shares > 0
        logs = [part.log_density(z) for part, share in zip(parts, shares, strict=True) if share > 0]
        return _logsumexp(np.stack(logs) + np.log(shares[used])[:, None], axis=0)

    def log_weights(self, z: np.ndarray) -> np.ndarray:
        """``log(nominal / proposal)`` at each row of ``z``."""
        return nominal_log_density(z) - self.log_density(z)


def gaussian_proposal(mean: np.ndarray, cov: np.ndarray,
                      defensive_fraction: float = 0.0) -> Proposal:
    """``N(mean, cov)``, mixed with the nominal by ``defensive_fraction``."""
    return Proposal((gaussian(mean, cov),), (1.0,), defensive_fraction)


def nominal_proposal(dims: int) -> Proposal:
    return Proposal((standard_normal(dims),), (1.0,))


def effective_sample_size(weights: np.ndarray) -> float:
    """Kish's ``(sum w)^2 / sum w^2``: how many equally weighted points the weights are worth."""
    weights = np.asarray(weights, dtype=float)
    return float(weights.sum() ** 2 / np.sum(weights * weights)) if weights.any() else 0.0


def kernel_mixture_fit(z: np.ndarray, log_weights: np.ndarray,
                       shrinkage: float, bandwidth_scale: float = 1.0) -> KernelMixture:
    """A Gaussian kernel at each elite point ``z``, weighted by its likelihood ratio.

    The weighted kernel density estimate of the elites' distribution under the
    nominal (the non-parametric adaptive IS update): where the elites lie in
    several regions, so does the proposal, each with the weight its points
    carry. The kernels' covariance is Silverman's rule, ``(4 / ((d + 2) n))^(2 /
    (d + 4)) C``, with n the Kish ESS of the weights and C the weighted
    covariance of the elites shrunk towards the identity, ``(1 - s) C + s I``:
    without the shrinkage a level's kernels are as thin across the failure
    boundary as its elites' strip, the next level's elites thinner still, and
    the levels stall short of failure (measured on a half-space at d = 2).
    ``bandwidth_scale`` multiplies that covariance: kernels twice Silverman's
    make heavier-tailed proposals, whose weights and error bars stayed honest
    on the whole bank where Silverman's own under-covered (82-88 % at d = 6).
    """
    w = np.exp(log_weights - np.max(log_weights))
    w /= w.sum()
    keep = w > _NEGLIGIBLE_MIX * w.max()
    z, w = z[keep], w[keep] / w[keep].sum()
    dims = z.shape[1]
    centred = z - w @ z
    cov = (1.0 - shrinkage) * ((centred * w[:, None]).T @ centred) + shrinkage * np.eye(dims)
    ess = 1.0 / float(np.sum(w * w))
    factor = bandwidth_scale * (4.0 / ((dims + 2) * ess)) ** (2.0 / (dims + 4))
    return KernelMixture(z, w, factor * cov)


def wide_normal(dims: int, scale: float) -> KernelMixture:
    """``N(0, scale^2 I)``: the exploration share of both samplers (see the docstring)."""
    return gaussian(np.zeros(int(dims)), scale ** 2 * np.eye(int(dims)))
