"""Collecting a run's trace rows step by step (the trace itself:
:mod:`analysis.measures.trace_file`)."""

from __future__ import annotations

import numpy as np

from analysis.measures.trace_file import FLOAT_COLUMNS, Trace


class TraceRecorder:
    """Collects rows during a run; :meth:`finish` turns them into a :class:`Trace`."""

    def __init__(self):
        self._floats: list[tuple[float, ...]] = []
        self._phase: list[str] = []
        self._lidar: list[np.ndarray] = []
        self._traffic: list[np.ndarray] = []
        self._classes: list[list[str]] = []
        self._bodies: list[list[int]] = []
        self._signals: list[str] = []

    def add(self, floats: tuple[float, ...], phase: str, lidar: np.ndarray,
            traffic: np.ndarray, traffic_classes: np.ndarray,
            traffic_bodies: np.ndarray | None = None, signals: str = "") -> None:
        """One step's row; ``floats`` holds the values of ``FLOAT_COLUMNS``, in order;
        ``traffic_classes`` the vehicle class of each traffic box, ``traffic_bodies``
        which body each is of (None: each its own); ``signals`` the lights along the
        route (``SIGNAL_COLUMN``)."""
        if len(floats) != len(FLOAT_COLUMNS):
            raise ValueError(f"a row has {len(FLOAT_COLUMNS)} floats, not {len(floats)}")
        self._floats.append(floats)
        self._phase.append(phase)
        self._lidar.append(np.asarray(lidar, np.float32))
        self._traffic.append(np.asarray(traffic, np.float32).ravel())
        self._classes.append(list(traffic_classes))
        self._bodies.append([] if traffic_bodies is None else np.asarray(traffic_bodies).tolist())
        self._signals.append(signals)

    def finish(self) -> Trace:
        columns = np.array(self._floats, dtype=float).reshape(-1, len(FLOAT_COLUMNS)).T
        floats = {name: np.ascontiguousarray(column)
                  for name, column in zip(FLOAT_COLUMNS, columns, strict=True)}
        return Trace(floats, list(self._phase), list(self._lidar), list(self._traffic),
                     list(self._classes), list(self._bodies), list(self._signals))
