from __future__ import annotations

import copy

import pytest

from scenarios import CATALOG_DIR
from scenarios.toml_io import read_toml


@pytest.fixture
def lesson_plain() -> dict:
    """The seed-lesson scenario as a plain mapping, to modify per test."""
    return copy.deepcopy(read_toml(CATALOG_DIR / "seed-lesson.toml"))
