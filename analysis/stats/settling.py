"""When has a town's background traffic settled? A warm-up length from the warm-up series.

The series, sampled about once a simulated second: ``t_s`` [s], ``vehicles`` (traffic
vehicles in the network), ``mean_speed_mps`` [m/s] and ``halting`` (those slower than
0.1 m/s). :func:`suggest_warm_up_s` applies to each measure the Marginal Standard
Error Rule on batch means of one correlation length (MSER-L; White 1997, MSER-5 of
White, Cobb and Spratt 2000):

* batch means of ``L`` samples starting every 5 samples (overlapping when ``L > 5``);
  the cut ``d`` minimises ``MSER(d) = sum_{j > d} (Z_j - Zbar_d)^2 / (m - d)^2``,
  searched in the first half of the series;
* ``L`` (:func:`batch_length`) is one period when the measure's ACF has a peak above
  :data:`PERIOD_PEAK` after its first negative lobe, else twice the first lag where
  it falls below :data:`DECORRELATED`, never fewer than :data:`BATCH_SIZE` samples;
* a minimum in the last :data:`EDGE_FRACTION` of the half, or fewer than
  :data:`MIN_BATCHES` batches, means not settled: no suggestion, only a lower bound;
* the suggestion is the latest measure's cut, rounded up.

Why one correlation length: signalised traffic swings with the signal cycle, and
MSER-5's 5-s batch means of that swing hide the start-up transient (it cuts far too
early). Limits: a drift that starts late in the watch goes unseen; the cut scatters
by a cycle or more. Derivation and figures: docs/rare_events_and_warm_up.md, reproduced by
``python -m pytest tests/test_settling.py``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

#: the measures the rule is applied to, each on its own
MEASURES = ("mean_speed_mps", "halting", "vehicles")
#: fewest samples per batch mean (the "5" of MSER-5), the batch length of output
#: that is not autocorrelated
BATCH_SIZE = 5
#: the rule's name, as it goes into a suggestion
RULE = ("MSER-L, MSER on batch means of one correlation length L "
        "(White 1997; White, Cobb and Spratt 2000)")
#: fewest batches the rule is applied to; fewer: the series is too short to judge
MIN_BATCHES = 4
#: a minimum in this last part of the searched half is "on its edge": not settled
EDGE_FRACTION = 0.1
#: an ACF peak after the first negative lobe higher than this marks a period
PERIOD_PEAK = 0.5
#: below this the ACF counts as decorrelated
DECORRELATED = 1 / math.e


def batch_means(values: np.ndarray, batch_size: int = BATCH_SIZE) -> np.ndarray:
    """Means of consecutive batches of ``batch_size`` samples; a last, incomplete batch
    is dropped (:func:`overlapping_batch_means` with batches that do not overlap)."""
    return overlapping_batch_means(values, batch_size, step=batch_size)


def autocorrelation(values: np.ndarray, max_lag: int) -> np.ndarray | None:
    """The sample autocorrelation ``r_0..r_max_lag`` of ``values`` (the usual estimator:
    autocovariances over ``n``, mean removed; NaN samples count as the mean), or None
    when ``values`` has no variance."""
    centred = np.asarray(values, dtype=float)
    centred = np.nan_to_num(centred - np.nanmean(centred))
    variance = float(np.dot(centred, centred))
    if variance <= 1e-12 * max(1.0, float(np.nanmax(np.abs(values))) ** 2) * len(values):
        return None
    n = len(centred)
    return np.array([np.dot(centred[: n - k], centred[k:]) for k in range(max_lag + 1)]) \
        / variance


def _period(acf: np.ndarray) -> int | None:
    """The lag at which the series repeats itself best: of the ACF's positive lobes
    after its first negative one, the peak (a true local maximum, not the last lag)
    highest above :data:`PERIOD_PEAK`; None if there is none."""
    peak, height = None, PERIOD_PEAK
    lag = int(np.argmax(acf < 0)) if np.any(acf < 0) else len(acf)
    while lag < len(acf):
        lobe = np.flatnonzero(acf[lag:] > 0)  # the next positive lobe ...
        if not len(lobe):
            break
        start = lag + int(lobe[0])
        end = np.flatnonzero(acf[start:] <= 0)  # ... runs to the next lag at or below 0
        lag = start + int(end[0]) if len(end) else len(acf)
        top = start + int(np.argmax(acf[start:lag]))
        if top < len(acf) - 1 and acf[top] > height:
            peak, height = top, acf[top]
    return peak


def batch_length(values: np.ndarray) -> int:
    """Samples per batch for MSER on one measure: one period of its second half if it is
    periodic, else twice its decorrelation lag, at least :data:`BATCH_SIZE` (see the
    module's docstring)."""
    second_half = np.asarray(values, dtype=float)[len(values) // 2:]
    if np.sum(~np.isnan(second_half)) < 2 * BATCH_SIZE:
        return BATCH_SIZE
    acf = autocorrelation(second_half, max_lag=len(second_half) // 2)
    if acf is None:  # constant: nothing correlated
        return BATCH_SIZE
    period = _period(acf)
    if period is not None:
        return max(period, BATCH_SIZE)
    below = np.flatnonzero(acf < DECORRELATED)
    lag = int(below[0]) if len(below) else len(acf) - 1
    return max(2 * lag, BATCH_SIZE)


def mser_statistic(means: np.ndarray) -> np.ndarray:
    """MSER(d) for every truncation ``d = 0..m-1`` of the batch means ``Z_1..Z_m``:
    the sum of squared deviations of ``Z_{d+1}..Z_m`` from their mean, over
    ``(m - d)^2`` (White 1997). Computed from suffix sums, O(m)."""
    reversed_means = means[::-1]
    kept = np.arange(1, len(means) + 1, dtype=float)  # m - d, for d = m-1 .. 0
    suffix_sum = np.cumsum(reversed_means)
    suffix_squares = np.cumsum(reversed_means**2)
    squared_deviations = np.maximum(suffix_squares - suffix_sum**2 / kept, 0.0)
    return (squared_deviations / kept**2)[::-1]


def earliest_minimum(statistic: np.ndarray) -> int:
    """Where ``statistic`` is least, the earliest of values equal up to rounding."""
    ties = statistic <= statistic.min() + 1e-12 * statistic.max()
    return int(np.argmax(ties))


def edge_batch(last_d: int) -> int:
    """The first truncation ``d`` "on the edge" of the searched ``0..last_d``: its last
    :data:`EDGE_FRACTION`, at least ``last_d`` itself."""
    return last_d - max(1, round(EDGE_FRACTION * last_d)) + 1


def overlapping_batch_means(values: np.ndarray, batch_size: int,
                            step: int = BATCH_SIZE) -> np.ndarray:
    """Means of the batches of ``batch_size`` consecutive samples that start every
    ``step`` samples and lie wholly in ``values``: overlapping when ``batch_size >
    step``, the plain :func:`batch_means` when they are equal. NaN samples are left out
    of their batch's mean; a batch of NaN only has a NaN mean."""
    values = np.asarray(values, dtype=float)
    defined = ~np.isnan(values)
    sums = np.concatenate([[0.0], np.cumsum(np.where(defined, values, 0.0))])
    counts = np.concatenate([[0], np.cumsum(defined)])
    starts = np.arange(0, len(values) - batch_size + 1, step)
    batch_sums = sums[starts + batch_size] - sums[starts]
    batch_counts = counts[starts + batch_size] - counts[starts]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(batch_counts > 0, batch_sums / np.maximum(batch_counts, 1), np.nan)


def mser_truncation(values: np.ndarray, batch_size: int = BATCH_SIZE) -> tuple[int, bool]:
    """The MSER truncation point of one measure on batch means of ``batch_size``
    samples, as ``(samples to cut, settled)``. The batches start every
    :data:`BATCH_SIZE` samples (overlapping if longer, :func:`overlapping_batch_means`)
    and truncating ``d`` of them cuts ``d * BATCH_SIZE`` samples: the ``d`` that
    minimises MSER(d) over the first half of the series, the earliest if several tie
    (a constant measure: 0). Batches with no defined sample (NaN: e.g. no mean speed
    before the first vehicle) cannot be kept, so ``d`` starts after the last of them.
    ``settled`` is False when the minimum lies on the edge of the searched half
    (:func:`edge_batch`): the measure was still moving when the series ended; and when
    fewer than :data:`MIN_BATCHES` whole batches fit in the series, too short to tell
    (then the cut is half the series, as a lower bound)."""
    if len(values) // batch_size < MIN_BATCHES:
        return len(values) // 2, False
    means = overlapping_batch_means(values, batch_size)
    undefined = np.flatnonzero(np.isnan(means))
    first_d = int(undefined[-1]) + 1 if len(undefined) else 0
    last_d = len(values) // BATCH_SIZE // 2
    if first_d >= last_d:
        return last_d * BATCH_SIZE, False
    kept = means[first_d:]
    spread = float(np.ptp(kept))
    if spread <= 1e-12 * max(1.0, float(np.max(np.abs(kept)))):  # constant: no variance
        best_d = first_d
    else:  # centred and scaled, so that rounding cannot pass for variance
        statistic = mser_statistic((kept - kept.mean()) / spread)
        best_d = first_d + earliest_minimum(statistic[: last_d - first_d + 1])
    return best_d * BATCH_SIZE, best_d < edge_batch(last_d)


def round_up_s(time_s: float, step_s: float) -> float:
    """``time_s`` rounded up to the next multiple of ``step_s`` (a multiple stays)."""
    return float(math.ceil(round(time_s / step_s, 9)) * step_s)


def suggest_warm_up_s(series: pd.DataFrame, measures: Sequence[str] = MEASURES,
                      round_to_s: float = 10.0) -> dict:
    """A warm-up length for the traffic of ``series`` (columns ``t_s`` and the
    ``measures``, one row per sample, ``t_s`` increasing, at least one row), by MSER on
    batch means of one correlation length (see the module's docstring) applied to
    each measure on its own.

    The suggestion is the latest truncation time over the measures, rounded up to a
    multiple of ``round_to_s``. Returns a plain dict:

    * ``rule``: the rule's name;
    * ``measures``: per measure, ``batch_s`` (its batch length: samples per batch
      times the median sampling step), ``truncation_s`` (the time of the first sample
      kept) and ``settled`` (False: the minimum lay on the edge of the first half, or
      the series held fewer than :data:`MIN_BATCHES` batches);
    * ``settled``: every measure settled within the observed time;
    * ``warm_up_s``: the suggestion, or None when not settled: the series is too short
      to tell, and only ``warm_up_at_least_s`` (the latest truncation time, rounded
      up) is known;
    * ``observed_s``: the time of the last sample.
    """
    times_s = series["t_s"].to_numpy(dtype=float)
    if not len(times_s):
        raise ValueError("no samples: the series is empty")
    step_s = float(np.median(np.diff(times_s))) if len(times_s) > 1 else 0.0
    per_measure = {}
    for measure in measures:
        values = series[measure].to_numpy(dtype=float)
        batch = batch_length(values)
        cut_samples, settled = mser_truncation(values, batch)
        per_measure[measure] = {"batch_s": round(batch * step_s, 3),
                                "truncation_s": float(times_s[cut_samples]),
                                "settled": bool(settled)}
    latest_s = max(m["truncation_s"] for m in per_measure.values())
    all_settled = all(m["settled"] for m in per_measure.values())
    at_least_s = round_up_s(latest_s, round_to_s)
    return {"rule": RULE, "measures": per_measure, "settled": all_settled,
            "warm_up_s": at_least_s if all_settled else None,
            "warm_up_at_least_s": at_least_s, "observed_s": float(times_s[-1])}
