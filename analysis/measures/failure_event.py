"""The failure event of search and estimate: which runs fail, the one home of
``score <= 0``.

As OpenTURNS models a reliability study, an event says which outcomes are failures, an
algorithm draws runs toward it (the search of :mod:`analysis.rare.mode_search`, the
estimate of :mod:`analysis.rare.rare_events`) and its result is about that event (the
failures found, a probability with its interval). :class:`FailureEvent` is the event
over a run's score (:mod:`analysis.measures.run_score`): a run fails when its score is at
or below :attr:`FailureEvent.threshold`, 0. The runner that scores the rows, the
samplers, the bank's problems (:mod:`analysis.rare.rare_bank`), the summaries and the
report all ask it.

The no-outcome rule: a run with no outcome (status error or timeout) scores 0 and
fails, the conservative reading; a sample that made no valid scenario had no run and
has no score (None in its row, NaN in a table, +inf told to a sampler): no evidence
either way, never a failure.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from analysis.measures.row_columns import RowCol
from analysis.measures.run_score import ScoreKind, run_score

if TYPE_CHECKING:
    import pandas as pd


@dataclasses.dataclass(frozen=True)
class FailureEvent:
    """A run fails when its ``score`` (the measure :func:`~analysis.measures.run_score.run_score`
    reads, ``--score``) is at or below :attr:`threshold`."""

    score: ScoreKind = "gap"
    #: fixed: a collision scores 0, so the samplers' levels stop there
    threshold: ClassVar[float] = 0.0

    def run_score(self, row: Mapping[str, Any]) -> float:
        """A result row's score (0 for a run with no outcome: it fails)."""
        return run_score(row, self.score)

    def fails(self, scores):
        """Per score (a float or an array of them; +inf never fails): at or below the
        threshold? What the samplers and the bank's problems ask of their scores."""
        return np.asarray(scores, dtype=float) <= self.threshold

    def failed(self, score: float | None) -> bool:
        """Did the run of a row whose score is ``score`` fail (None: no run, no failure)?"""
        return score is not None and score <= self.threshold

    def failed_rows(self, rows: pd.DataFrame) -> pd.Series:
        """Per row of a table with a ``score`` column: did it fail (NaN or None: no run,
        no failure)?"""
        return rows[RowCol.score].notna() & (rows[RowCol.score] <= self.threshold)

    @staticmethod
    def told(score: float | None) -> float:
        """What a sampler is told of a row's score: +inf for a sample with no run, which
        is kept but never leads it."""
        return math.inf if score is None else score


#: the event as the samplers and the bank see it: scores already made, of any kind
FAILURE = FailureEvent()
