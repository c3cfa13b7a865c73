"""Background demand on a SUMO network: random trips, like SUMO's ``randomTrips.py -l``.

``traffic.vehicles`` cars start on trips at 0 s. Each car that arrives is
replaced by a new trip, so the network holds about that many cars for the
whole run (without, a grid of 2000 loses about 5% a minute). Trips are drawn
from the seed's ``DEMAND`` stream, in order, so a run's demand is reproducible.
"""

from __future__ import annotations

import numpy as np

from scenarios.common.errors import SpecError
from scenarios.sumo_net.net_xml import NetFile


def trip_edges(net: NetFile) -> list[tuple[str, float]]:
    """The edges trips start and end on, with their lengths; a network with fewer
    than two (a trip never ends where it starts) is a :class:`SpecError`."""
    edges = net.trip_edges()
    if len(edges) < 2:
        raise SpecError("traffic.vehicles", f"{net.path}: random trips need two edges open "
                        f"to cars, the network has {len(edges)}")
    return edges


class RandomTrips:
    """Trips between a network's edges: both ends drawn in proportion to the edge's
    length, never the same edge twice."""

    def __init__(self, net: NetFile, rng: np.random.Generator):
        edges = trip_edges(net)
        self.edge_ids = [edge for edge, _ in edges]
        lengths_m = np.array([length_m for _, length_m in edges])
        self._chance = lengths_m / lengths_m.sum()
        self._rng = rng

    def state(self) -> dict:
        """Where the generator stands (plain data): :meth:`restore` continues from it."""
        return self._rng.bit_generator.state

    def restore(self, state: dict) -> None:
        self._rng.bit_generator.state = state

    def draw(self, count: int) -> list[tuple[str, str]]:
        """The next ``count`` trips as (from edge, to edge)."""
        rng, chance, n = self._rng, self._chance, len(self.edge_ids)
        ends = rng.choice(n, size=(count, 2), p=chance)
        while np.any(same := ends[:, 0] == ends[:, 1]):
            ends[same, 1] = rng.choice(n, size=int(same.sum()), p=chance)
        return [(self.edge_ids[a], self.edge_ids[b]) for a, b in ends.tolist()]
