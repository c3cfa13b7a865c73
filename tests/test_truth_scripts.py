"""The truth scripts check a truth before they write it (truths/): the committed truth
files pass those checks, and a truth that fails one is printed but never written."""

from __future__ import annotations

import copy
import importlib
import json
import sys
from pathlib import Path

import pytest

from scenarios import CATALOG_DIR

TRUTHS = Path(__file__).resolve().parents[1] / "truths"


@pytest.fixture
def script(monkeypatch):
    """A truth script by name, imported as it runs (beside its truth_sweeps helper)."""
    monkeypatch.syspath_prepend(str(TRUTHS))
    yield importlib.import_module
    for name in ("seed_rare_truth", "seed_modes_truth", "truth_sweeps"):
        sys.modules.pop(name, None)


@pytest.mark.parametrize("name, family, break_it", [
    ("seed_rare_truth", "seed-rare", lambda t: t["check"].update(outcome_mismatches=3)),
    ("seed_modes_truth", "seed-modes", lambda t: t["modes"][0].update(p=t["p_true"])),
])
def test_a_truth_is_written_only_when_its_checks_hold(script, tmp_path, capsys, name, family,
                                                      break_it):
    module = script(name)
    committed = json.loads((CATALOG_DIR / "sweeps" / f"{family}.truth.json").read_text())
    assert module.failed_checks(committed) == []
    broken = copy.deepcopy(committed)
    break_it(broken)
    failed = module.failed_checks(broken)
    assert failed
    out = tmp_path / "truth.json"
    assert module.publish(broken, failed, out, write=True) == 1 and not out.exists()
    assert failed[0] in capsys.readouterr().err
    assert module.publish(committed, [], out, write=True) == 0
    assert json.loads(out.read_text()) == committed
