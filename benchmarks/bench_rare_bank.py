"""The rare-event estimator on the bank of problems with exact truths, beside OpenTURNS NAIS.

For each problem of :mod:`analysis.rare.rare_bank` (target RHW 0.3, ``SEEDS`` seeds):
coverage of the 95 % interval, mean estimate over the truth, the mean
coefficient of variation the estimates reported against the error they made
(root mean square of ``p / truth - 1``), and the median runs. Then OpenTURNS'
NAIS (quantile level 0.1, 1,000 samples per level: the reference the issue
measured) on the same problems over ``REFERENCE_SEEDS`` seeds, when the
``openturns`` package is installed (a benchmark-only extra: ``pip install
openturns``; sdc does not use it at run time).

Prints a table, then ``name value`` lines:
``bank_<problem>_coverage``, ``..._mean_over_truth``, ``..._error_ratio``
(reported over measured error: 1 is honest), ``..._median_runs``, and the
same with ``nais_`` for the reference.

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): 2 seeds a problem (and
2 for the reference).
"""

from __future__ import annotations

import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from smoke import size  # noqa: E402

from analysis.rare.rare_bank import BANK, BankResult, problem, run_bank  # noqa: E402

SEEDS = size(200, 2)
REFERENCE_SEEDS = size(100, 2)
WORKERS = 2
CHUNK = size(25, 1)


def _ours(args: tuple[str, int]) -> BankResult:
    name, first = args
    return run_bank(problem(name), range(first, min(first + CHUNK, SEEDS)))


def _merge(parts: list[BankResult]) -> BankResult:
    """One result from per-chunk results (weighted by seeds; medians of medians are close)."""
    n = np.array([r.seeds for r in parts], dtype=float)
    mean = lambda values: float(np.sum(n * np.array(values)) / n.sum())  # noqa: E731
    return BankResult(parts[0].problem, int(n.sum()), mean([r.coverage for r in parts]),
                      mean([r.mean_over_truth for r in parts]),
                      mean([r.reported_cov for r in parts]),
                      math.sqrt(mean([r.measured_error ** 2 for r in parts])),
                      float(np.median([r.median_runs for r in parts])),
                      sum(r.budget_stops for r in parts))


def _nais(args: tuple[str, int]) -> tuple[float, float, float, int]:
    """One OpenTURNS NAIS estimate: p, its reported CoV, covered (0/1), evaluations."""
    import openturns as ot

    name, seed = args
    case = problem(name)
    ot.RandomGenerator.SetSeed(seed)
    model = ot.PythonFunction(case.dims, 1, func_sample=lambda x: np.asarray(
        case.score(np.asarray(x)))[:, None])
    output = ot.CompositeRandomVector(model, ot.RandomVector(ot.Normal(case.dims)))
    algo = ot.NAIS(ot.ThresholdEvent(output, ot.LessOrEqual(), 0.0), 0.1)
    algo.setMaximumOuterSampling(1000)
    algo.run()
    result = algo.getResult()
    p = result.getProbabilityEstimate()
    half = result.getConfidenceLength(0.95) / 2
    return p, result.getCoefficientOfVariation(), float(p - half <= case.truth <= p + half), \
        model.getEvaluationCallsNumber()


def _nais_bank(pool: ProcessPoolExecutor, name: str) -> BankResult | None:
    try:
        import openturns  # noqa: F401
    except ImportError:
        return None
    truth = problem(name).truth
    found = list(pool.map(_nais, [(name, seed) for seed in range(1, REFERENCE_SEEDS + 1)]))
    p = np.array([f[0] for f in found])
    return BankResult(name, len(found), float(np.mean([f[2] for f in found])),
                      float(p.mean() / truth), float(np.mean([f[1] for f in found])),
                      float(np.sqrt(np.mean((p / truth - 1) ** 2))),
                      float(np.median([f[3] for f in found])), 0)


def main() -> None:
    rows = []
    with ProcessPoolExecutor(WORKERS) as pool:
        for case in BANK:
            start = time.perf_counter()
            ours = _merge(list(pool.map(_ours, [(case.name, first)
                                               for first in range(0, SEEDS, CHUNK)])))
            wall_s = time.perf_counter() - start
            rows.append(("sdc", ours, wall_s))
            start = time.perf_counter()
            nais = _nais_bank(pool, case.name)
            if nais is not None:
                rows.append(("nais", nais, time.perf_counter() - start))
    print(f"{'estimator':9s} {'problem':18s} {'seeds':>5s} {'coverage':>8s} {'mean/truth':>10s} "
          f"{'reported CoV':>12s} {'measured err':>12s} {'ratio':>6s} {'median runs':>11s}",
          file=sys.stderr)
    for who, r, wall_s in rows:
        print(f"{who:9s} {r.problem:18s} {r.seeds:5d} {r.coverage:8.2f} {r.mean_over_truth:10.3f} "
              f"{r.reported_cov:12.3f} {r.measured_error:12.3f} {r.error_ratio:6.2f} "
              f"{r.median_runs:11.0f}  ({wall_s:.0f} s)", file=sys.stderr)
    for who, r, _ in rows:
        prefix = f"{'bank' if who == 'sdc' else 'nais'}_{r.problem.replace('-', '_')}"
        print(f"{prefix}_coverage {r.coverage:.3f}")
        print(f"{prefix}_mean_over_truth {r.mean_over_truth:.3f}")
        print(f"{prefix}_error_ratio {r.error_ratio:.2f}")
        print(f"{prefix}_median_runs {r.median_runs:.0f}")


if __name__ == "__main__":
    main()
