"""Seeds and the random streams a sweep draws from its seed.

Why one place: every seed a user or a sweep gives is in ``[0, SEED_LIMIT)``,
and each use of a sweep's seed draws from a stream of its own, so adding a use
never shifts the draws of another (and a resumed sweep draws what it drew).
"""

from __future__ import annotations

import numpy as np

#: every seed is in [0, SEED_LIMIT): a non-negative 32-bit signed integer
SEED_LIMIT = 2**31
#: the streams of a sweep's seed: children of ``SeedSequence(seed)``
POINTS_STREAM = 0  # where each sample lies in the unit cube
RUN_SEEDS_STREAM = 1  # each sample's scenario seed
SAMPLER_STREAM = 2  # an adaptive sampler's draws (search, estimate)
#: the warm-up seeds: ``default_rng([seed, WARM_STREAM])``, apart from the children above
WARM_STREAM = 3


def stream_rng(seed: int, stream: int) -> np.random.Generator:
    """The generator of one of a sweep seed's child streams (``*_STREAM`` above but
    :data:`WARM_STREAM`)."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(stream + 1)[stream])


def warm_rng(seed: int) -> np.random.Generator:
    """The generator of a sweep's warm-up seeds."""
    return np.random.default_rng([seed, WARM_STREAM])


def draw_seeds(rng: np.random.Generator, count: int) -> list[int]:
    """``count`` scenario seeds (below ``SEED_LIMIT - 1``: how they were always drawn)."""
    return [int(seed) for seed in rng.integers(0, SEED_LIMIT - 1, size=count)]
