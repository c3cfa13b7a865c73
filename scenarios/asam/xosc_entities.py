"""What an OpenSCENARIO entity is, as sdc holds it: its kind of body, its category as
the file gives it, and its bounding box.

- ``Vehicle`` by ``vehicleCategory``: car and van a ``"car"``; truck, bus,
  semitrailer and trailer a ``"truck"``; bicycle and motorbike (a stopped two-wheeler)
  a ``"bicycle"``; train and tram refused, and so is a vehicle towing a ``Trailer``.
- ``Pedestrian``: pedestrian and wheelchair a ``"pedestrian"`` (a standing person),
  animal refused.
- ``MiscObject``: a ``"barrel"`` when its bounding box is at most
  :data:`BARREL_MAX_M` long and wide, else a ``"box"`` (sdc has no such obstacle kind
  yet: the caller decides); flat categories (parkingSpace, patch, crosswalk,
  roadMark) refused.
- Any other entity (an ``ExternalObjectReference``, say) is refused.

Every entity keeps its bounding box's size (length, width, height; each must be
positive) and its ``center_m``: the box's centre from the entity's reference point (a
vehicle's rear axle; x forward, y left, z up), for the caller to place its centre.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from scenarios.asam.xosc_document import Doc, attr_float, attr_text

#: vehicleCategory -> sdc's obstacle kind (train and tram are refused)
VEHICLE_KINDS = {"car": "car", "van": "car", "truck": "truck", "bus": "truck",
                 "semitrailer": "truck", "trailer": "truck", "bicycle": "bicycle",
                 "motorbike": "bicycle"}
#: pedestrianCategory -> kind (animal is refused)
PEDESTRIAN_KINDS = {"pedestrian": "pedestrian", "wheelchair": "pedestrian"}
#: the miscObjectCategory values of things that stand on the road (the flat ones,
#: parkingSpace, patch, crosswalk and roadMark, are refused)
MISC_SOLID = ("none", "obstacle", "pole", "tree", "vegetation", "barrier", "building",
              "railing", "trafficIsland", "streetLamp", "gantry", "soundBarrier", "wind")
#: a MiscObject at most this long and wide [m] is a "barrel" (sdc's is 0.6 m), else a "box"
BARREL_MAX_M = 1.0


def bounding_box(doc: Doc, entity: ET.Element):
    box = entity.find("BoundingBox")
    dimensions = None if box is None else box.find("Dimensions")
    center = None if box is None else box.find("Center")
    if dimensions is None or center is None:
        raise doc.error(entity, f"{entity.tag} has no BoundingBox with Center and Dimensions")
    size = tuple(attr_float(doc, dimensions, key) for key in ("length", "width", "height"))
    if min(size) <= 0:
        raise doc.error(dimensions, f"a {entity.tag}'s Dimensions must be positive, got "
                                    f"length, width, height {size}")
    return size, tuple(attr_float(doc, center, key) for key in ("x", "y", "z"))


def kind_of(doc: Doc, entity: ET.Element) -> tuple[str, str]:
    """An entity's (kind, category)."""
    if entity.tag == "Vehicle":
        if entity.find("Trailer") is not None:
            raise doc.outside(entity.find("Trailer"), "a vehicle towing a trailer")
        category = attr_text(doc, entity, "vehicleCategory")
        kinds = VEHICLE_KINDS
    elif entity.tag == "Pedestrian":
        category = attr_text(doc, entity, "pedestrianCategory")
        kinds = PEDESTRIAN_KINDS
    elif entity.tag == "MiscObject":
        category = attr_text(doc, entity, "miscObjectCategory")
        if category not in MISC_SOLID:
            raise doc.error(entity, f"a MiscObject of category {category} is outside the "
                                    f"subset sdc runs (it reads {', '.join(MISC_SOLID)})",
                            "miscObjectCategory")
        (length, width, _), _ = bounding_box(doc, entity)
        return ("barrel" if max(length, width) <= BARREL_MAX_M else "box"), category
    else:
        raise doc.outside(entity, "an entity is a Vehicle, Pedestrian, MiscObject or a "
                                  "CatalogReference to one")
    if category not in kinds:
        raise doc.error(entity, f"a {entity.tag} of category {category} is outside the "
                                f"subset sdc runs (it reads {', '.join(kinds)})")
    return kinds[category], category
