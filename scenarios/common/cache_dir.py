"""Where sdc caches what it builds once (road networks, their road edges).

``$SDC_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/sdc`` (an absolute
``XDG_CACHE_HOME`` only, as the XDG base directory spec asks), else
``~/.cache/sdc``. The environment is read on each call, never at import.
"""

from __future__ import annotations

import os
from pathlib import Path


def sdc_cache_dir() -> Path:
    """The root of sdc's cache."""
    if override := os.environ.get("SDC_CACHE_DIR"):
        return Path(override)
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg and Path(xdg).is_absolute():
        return Path(xdg) / "sdc"
    return Path.home() / ".cache" / "sdc"


def network_cache_dir() -> Path:
    """Built networks (``.net.xml``) and networks' road edges (``.npy``)."""
    return sdc_cache_dir() / "networks"
