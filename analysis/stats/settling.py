"""When has a town's background traffic settled? A warm-up length from the warm-up series.

While the traffic warms up the simulator records, about once a simulated second,
``t_s`` (simulation time [s]), ``vehicles`` (traffic vehicles in the network),
``mean_speed_mps`` (their mean speed [m/s]) and ``halting`` (those slower than
0.1 m/s). :func:`suggest_warm_up_s` reads the end of the start-up transient off
that series with a standard warm-up truncation rule of simulation output analysis,
the Marginal Standard Error Rule (MSER) on batch means, here on **batch means of one
correlation length** (MSER-L):

* White, K. P. Jr. (1997), "An effective truncation heuristic for bias reduction
  in simulation output", *Simulation* 69(6), 323-334 (the rule, as MCR/MSER);
* White, K. P. Jr., Cobb, M. J. and Spratt, S. C. (2000), "A comparison of five
  steady-state truncation heuristics for simulation", *Proc. Winter Simulation
  Conference*, 755-760 (MSER-5: the rule on batch means of 5).

The rule, for one measure, with batches of ``L`` samples (below): take the means
``Z_1..Z_m`` of the batches that start every 5 samples (at samples 0, 5, 10, ...) and
lie wholly in the series. With ``L = 5`` they are the consecutive batches of MSER-5;
with ``L > 5`` they overlap (overlapping batch means: Meketon, M. S. and Schmeiser,
B. (1984), "Overlapping batch means: something for nothing?", *Proc. Winter
Simulation Conference*, 227-230), which keeps the rule's resolution at 5 samples and
estimates the same standard error with less noise than disjoint batches of ``L``.
Truncating the first ``d`` batches cuts ``5 d`` samples and leaves ``Z_{d+1}..Z_m``,
with mean ``Zbar_d``; the rule's statistic is

    MSER(d) = sum_{j > d} (Z_j - Zbar_d)^2 / (m - d)^2,

proportional to the squared standard error of the remaining mean, as long as ``L``
spans the measure's correlation, so that batch means ``L`` apart are about
independent. The truncation point is the ``d`` that minimises it: cutting more
removes the bias of the transient, cutting too much leaves too little data and the
error grows again. As is customary (e.g. Hoad, Robinson and Davies 2010), the cut is
searched in the first half of the series only. A minimum on the edge of that half
means the series had not settled within the observed time, and then no warm-up is
suggested, only a lower bound. "On the edge" takes in the last tenth of the half
(:data:`EDGE_FRACTION`): on a series still trending at its end the statistic falls
all the way to the edge, and its noise alone moves the minimum a little inward. A
series holding fewer than :data:`MIN_BATCHES` whole batches of ``L`` is too short
to judge: not settled either, with half the series as the lower bound.

**The batch length L: MSER on batch means of one correlation length (MSER-L).**
MSER-5 fixes ``L = 5``, enough for output whose samples are nearly independent.
Traffic in a signalised town is not: its mean speed and the number halting swing
with the signal cycle (tens of seconds), and 5-s batch means of such a swing are
strongly correlated. Their spread is then mostly the swing, against which the
start-up transient does not stand out, and MSER-5 cuts far too early (on a 45-s
sawtooth with a 60-s start-up: after 15-20 s). So ``L`` is read off each measure's
own autocorrelation function (ACF), estimated on the second half of the series
(closer to steady state than the first), mean removed, at lags up to half of that
half (:func:`batch_length`):

1. periodic: the period is the lag at which the measure repeats itself best: of the
   positive lobes of the ACF after its first negative one, the peak (a true local
   maximum, not the last lag looked at) that is highest, if it is above
   :data:`PERIOD_PEAK`; ``L`` is one period, and a mean over a whole cycle averages
   the cycle out, whatever its phase. Usually that is the first peak: the ACF
   estimator shrinks a peak at lag ``k`` by ``1 - k/n``, so a multiple of the period
   wins only where the series repeats itself clearly better there. It does in a town
   whose signals switch between two phases: the halves of the cycle differ, and
   batches of one half would alternate high and low, far from independent. The
   threshold 0.5 is well above the noise of the ACF at such lags (on AR(1) noise,
   phi = 0.9, over 600 s: a "period" in 47 of 1000 seeds at 0.3, in none at 0.5);
2. otherwise: ``L`` is twice the first lag at which the ACF falls below
   :data:`DECORRELATED` = 1/e; for an AR(1) process that is about its integrated
   autocorrelation time ``(1 + phi) / (1 - phi)``, the spacing of effectively
   independent samples. If the ACF never falls that low within the lags looked at,
   ``L`` is twice the largest lag, and the series is too short to judge;
3. never fewer than :data:`BATCH_SIZE` = 5 samples: on uncorrelated output the rule
   is MSER-5.

Limits. A cycle shows in the ACF only if the series spans at least four of them
(the lags reach a quarter of the series), as many as :data:`MIN_BATCHES` one-cycle
batches need anyway; on a shorter series of periodic traffic the rule falls back to
case 2 and is no better than MSER-5: watch longer. MSER sees a transient only as a
start that differs from the rest: a drift that begins late, in the second half,
raises every MSER(d) alike and passes unnoticed (on a 10 x 10 grid of signals whose
cycle means drifted from about 250 s to 550 s, 600 s of it gave 30 s, 900 s "not
settled, at least 450 s"): watch well past where the measures look flat. And MSER's
minimum scatters on stationary output by a few batches (it drops an early batch that
happens to lie off the mean), in batches whatever their number: with one-cycle
batches, by a cycle or more. On 900 s of a 45-s sawtooth with noise, the suggestion
is within 50 s in 70 % of seeds without a start-up transient, and with a 60-s one it
is 45-150 s in 75 % (exactly 60 s in 44 %); 4 % are not settled.

:func:`analysis.report.settling_report.settling_figure` draws the series and the
suggestion.
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
