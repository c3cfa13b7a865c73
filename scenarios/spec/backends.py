"""What each world backend can do, asked of it wherever a run or a sweep depends on
it (never by comparing a backend's name): ``scenario.backend`` names one, and
``spec.scenario.world_backend`` is it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Backend:
    name: str
    #: loads SUMO networks: network, configuration and OpenDRIVE roads run on it, and
    #: a sweep builds their networks and ships their files before the runs
    loads_networks: bool
    #: saves its warmed-up traffic as a warm state a run starts from (and `sdc settle`
    #: watches it settle)
    warm_states: bool
    holds_several_egos: bool  # several runs share one world (`[sweep] egos_per_world`)
    has_gui: bool  # `--gui` shows its world as it runs


#: every backend, by name (``scenarios.world_backends`` builds their worlds)
BACKENDS = {b.name: b for b in (
    Backend("sumo", loads_networks=True, warm_states=True, holds_several_egos=True,
            has_gui=True),
    Backend("highway", loads_networks=False, warm_states=False, holds_several_egos=False,
            has_gui=False),
    Backend("scripted", loads_networks=False, warm_states=False, holds_several_egos=False,
            has_gui=False),
)}

