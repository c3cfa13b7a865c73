"""How many runs a Ray task carries: enough that the cost of a task (its
submission, scheduling and the round trip of its first row) is small beside its
runs, few enough that every slot gets work and the sweep's tail stays short.
"""

from __future__ import annotations

import math

TARGET_TASK_S = 0.3  # a task's aimed length [s]
MAX_RUNS = 64  # never more runs in one task
SMOOTHING = 0.2  # weight of the newest run time in the running average


class BatchSizer:
    """Batch sizes from run times measured as they come (``fixed_runs``: the
    user's ``--batch N`` instead). The first task of each slot carries one run."""

    def __init__(self, fixed_runs: int | None = None, target_task_s: float = TARGET_TASK_S,
                 max_runs: int = MAX_RUNS):
        self.fixed_runs, self.target_task_s, self.max_runs = fixed_runs, target_task_s, max_runs
        self.mean_run_s: float | None = None  # exponentially smoothed

    def observe(self, run_s: float) -> None:
        """One run took ``run_s`` as the driver saw it (from the previous row of its
        task, or from the task's submission)."""
        self.mean_run_s = (run_s if self.mean_run_s is None
                           else (1 - SMOOTHING) * self.mean_run_s + SMOOTHING * run_s)

    def size(self, pending: int, slots: int) -> int:
        """Runs for the next task, with ``pending`` runs waiting for ``slots`` slots:
        never more than a ``1 / (2 slots)`` share of them, so every slot gets work
        and none idles while another holds a long queue (also under ``--batch``)."""
        if self.fixed_runs is not None:
            wanted = self.fixed_runs
        elif self.mean_run_s is None:
            wanted = 1
        else:
            wanted = min(round(self.target_task_s / max(self.mean_run_s, 1e-6)), self.max_runs)
        return max(1, min(wanted, math.ceil(pending / (2 * max(slots, 1)))))
