"""The argument checks the ask/tell samplers share (:mod:`analysis.rare.multilevel_is`,
:mod:`analysis.rare.mode_search`): dimensions, batch and budget, kernel options, a told
batch."""

from __future__ import annotations

import numpy as np


def check_dims(dims: int) -> None:
    if not isinstance(dims, int | np.integer) or dims < 1:
        raise ValueError(f"dims must be a positive integer, got {dims!r}")


def check_budget(batch_size: int, max_runs: int | None = None) -> None:
    """A batch of at least 2 runs and, with ``max_runs``, room for two batches."""
    if batch_size < 2:
        raise ValueError(f"batch_size must be at least 2, got {batch_size!r}")
    if max_runs is not None and max_runs < 2 * batch_size:
        raise ValueError(f"max_runs={max_runs} is too small to adapt: at least 2 batches "
                         f"({2 * batch_size} runs)")


def check_kernels(elite_fraction: float, shrinkage: float, bandwidth_scale: float,
                  explore_scale: float) -> None:
    """The options both samplers' kernel fits and wide Gaussians share."""
    if not 0 < elite_fraction < 1:
        raise ValueError(f"elite_fraction must be in (0, 1), got {elite_fraction!r}")
    if not 0 < shrinkage <= 1:  # 0 would give a lone elite a singular kernel
        raise ValueError(f"shrinkage must be in (0, 1], got {shrinkage!r}")
    if not bandwidth_scale > 0:
        raise ValueError(f"bandwidth_scale must be > 0, got {bandwidth_scale!r}")
    if not explore_scale > 0:
        raise ValueError(f"explore_scale must be > 0, got {explore_scale!r}")


def checked_batch(z: np.ndarray, scores: np.ndarray, dims: int) -> tuple[np.ndarray, np.ndarray]:
    """A told batch as float arrays, or ValueError naming what is wrong with it."""
    z = np.asarray(z, dtype=float)
    scores = np.asarray(scores, dtype=float)
    if z.ndim != 2 or z.shape[1] != dims:
        raise ValueError(f"z must have shape (n, {dims}), got {z.shape}")
    if scores.shape != (z.shape[0],):
        raise ValueError(f"scores must have shape ({z.shape[0]},), got {scores.shape}")
    if np.any(np.isnan(scores)):
        raise ValueError("scores contain NaN: score every run (+inf for a run with no outcome)")
    return z, scores
