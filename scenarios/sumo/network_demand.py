"""A network road's background traffic: ``traffic.vehicles`` random trips
(:class:`scenarios.sumo_net.random_trips.RandomTrips`), drawn as SUMO starts, and a
new trip for every car that arrives, so the network keeps its count of cars.

A built road's traffic enters as flows per lane (``scenarios/sumo/routes_xml.py``)
and a configuration brings its own demand: neither has trips to draw.
"""

from __future__ import annotations

from collections.abc import Callable

from scenarios.scene.road_geometry import RoadGeometry
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.routes_xml import TRAFFIC_PREFIX
from scenarios.sumo_net.random_trips import RandomTrips
from scenarios.sumo_net.road_source import RoadSource
from scenarios.sumo_net.route_drawing import DEMAND, scenario_stream


class NetworkDemand:
    """The random trips of a world's traffic (``trips`` None: it has none) and how many
    it has made (``made``: the next trip's vehicle is ``traffic.<made>``)."""

    def __init__(self, trips: RandomTrips | None = None):
        self.trips = trips
        self.made = 0

    @classmethod
    def drawn(cls, spec: ScenarioSpec, road: RoadGeometry, source: RoadSource,
              seed: int) -> NetworkDemand:
        """The demand of ``spec``'s traffic on ``road``, drawn from ``seed``'s stream."""
        if source.flows or not spec.traffic.vehicles:
            return cls()
        return cls(RandomTrips(road.net, scenario_stream(seed, DEMAND)))

    def first(self, count: int) -> list[tuple[str, str]]:
        """The ``count`` trips SUMO starts with (from edge, to edge); none without trips."""
        trips = self.trips.draw(count) if self.trips else []
        self.made = len(trips)
        return trips

    def restore(self, saved: dict | None) -> None:
        """Go on where a warm-up left it (``saved``: :meth:`saved`'s)."""
        if self.trips is not None:
            self.trips.restore(saved["rng"])
            self.made = saved["trips_made"]

    def saved(self) -> dict | None:
        """Where it stands, as a warm state keeps it (None: no trips)."""
        if self.trips is None:
            return None
        return {"rng": self.trips.state(), "trips_made": self.made}

    def renew(self, sim, is_traffic: Callable[[str], bool]) -> None:
        """Every traffic car that arrived in SUMO's (``sim``: libsumo or traci) last step
        starts a new trip."""
        if self.trips is None:
            return
        arrived = [v for v in sim.simulation.getArrivedIDList() if is_traffic(v)]
        if not arrived:
            return
        for start, end in self.trips.draw(len(arrived)):
            vid = f"{TRAFFIC_PREFIX}{self.made}"
            self.made += 1
            # two edges not joined make a trip: SUMO routes it as the car enters
            sim.route.add(vid, [start, end])
            sim.vehicle.add(vid, vid, typeID="traffic", depart="now", departLane="random",
                            departPos="random_free", departSpeed="0")
