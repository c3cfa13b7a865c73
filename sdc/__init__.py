"""sdc: traffic-scale scenario simulator for self-driving-car maneuvers.

A controller plug-in needs only what this package exports::

    from sdc import Command, LanesBeside, Observation, StopLine

(loaded on first use, so ``python -m sdc`` checks its settings before any
kernel is imported)
"""

__all__ = ["Command", "LanesBeside", "Observation", "StopLine"]


def __getattr__(name: str):
    if name in __all__:
        from sdc.car import controller_api

        return getattr(controller_api, name)
    raise AttributeError(f"module 'sdc' has no attribute {name!r}")
