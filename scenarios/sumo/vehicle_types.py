"""What sdc sees of each traffic vehicle and person besides its pose: its type's
length, width and vehicle class (SUMO's ``vClass``: passenger, truck, bus, motorcycle,
bicycle, ...; a person on foot is always a ``pedestrian``), so that a truck is seen, hit
and measured as the 16.5 m it is, a bicycle as the bicycle and a person as the person.

Read from SUMO once per vehicle (its type id) and once per type (its size and
class), not every step: a subscribed variable costs on every vehicle at every step.
"""

from __future__ import annotations

import numpy as np

from scenarios.spec.bodies import PEDESTRIAN

#: classes that never drive in a road's lanes beside a car: persons, trains, ships
OFF_ROAD_CLASSES = frozenset({PEDESTRIAN, "rail", "rail_urban", "rail_electric", "rail_fast",
                              "ship", "aircraft", "wheelchair"})
#: the vehicle types SUMO always has (DEFAULT_VEHTYPE, DEFAULT_BIKETYPE, ...): no
#: vehicle of them unless a demand names them (then they are read with the vehicle)
SUMO_DEFAULT_PREFIX = "DEFAULT_"


class VehicleTypes:
    """The vehicles, persons and types met so far: ``sizes`` (vehicle or person id ->
    (length, width, class index), as :func:`scenarios.scene.road_kernels.traffic`
    reads it), ``classes`` (class index -> vClass), ``longest_m``, the longest traffic
    type loaded or met, and ``widest_m``, the widest of those that drive in a road's
    lanes (0 before any)."""

    def __init__(self):
        self.sizes: dict[str, tuple[float, float, float]] = {}
        self.classes = np.zeros(0, dtype=object)
        self.longest_m = 0.0
        self.widest_m = 0.0
        self._types: dict[str, tuple[float, float, float]] = {}
        self._listed = 0  # how many types SUMO listed when last asked

    def _type(self, type_id: str, vehicletype) -> tuple[float, float, float]:
        """(length, width, class index) of type ``type_id``, from SUMO's first time."""
        if type_id not in self._types:
            length_m, width_m = (float(vehicletype.getLength(type_id)),
                                 float(vehicletype.getWidth(type_id)))
            vclass = vehicletype.getVehicleClass(type_id)
            self._types[type_id] = (length_m, width_m, self._class_index(vclass))
            self.longest_m = max(self.longest_m, length_m)
            if vclass not in OFF_ROAD_CLASSES:
                self.widest_m = max(self.widest_m, width_m)
        return self._types[type_id]

    def _class_index(self, vclass: str) -> float:
        """The index of ``vclass`` in ``classes`` (added when new)."""
        found = np.flatnonzero(self.classes == vclass)
        if len(found):
            return float(found[0])
        self.classes = np.append(self.classes, np.array([vclass], dtype=object))
        return float(len(self.classes) - 1)

    def add(self, vehicle_ids, sumo) -> None:
        """Read the vehicles of ``vehicle_ids`` not met yet from ``sumo`` (libsumo or
        traci)."""
        for vid in vehicle_ids:
            if vid not in self.sizes:
                self.sizes[vid] = self._type(sumo.vehicle.getTypeID(vid), sumo.vehicletype)

    def add_persons(self, person_ids, sumo) -> None:
        """The same for persons: their type's size, the class :data:`PEDESTRIAN`."""
        for pid in person_ids:
            if pid not in self.sizes:
                length_m, width_m, _ = self._type(sumo.person.getTypeID(pid), sumo.vehicletype)
                self.sizes[pid] = (length_m, width_m, self._class_index(PEDESTRIAN))

    def refresh(self, vehicletype, not_traffic: tuple[str, ...]) -> None:
        """Read the types SUMO has loaded since last asked (``longest_m`` with them),
        but SUMO's own defaults and those whose id starts with one of ``not_traffic``
        (the ego's, the obstacles')."""
        listed = vehicletype.getIDCount()
        if listed != self._listed:
            self._listed = listed
            for type_id in vehicletype.getIDList():
                if not type_id.startswith((SUMO_DEFAULT_PREFIX, *not_traffic)):
                    self._type(type_id, vehicletype)

    def names(self, kinds: np.ndarray) -> np.ndarray:
        """The vClass of each class index in ``kinds``."""
        return self.classes[kinds.astype(np.intp)]
