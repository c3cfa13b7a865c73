"""The typed manifest: any version's manifest.json read and written back byte for byte,
and the runner's changes placed as a dict's would be."""

from __future__ import annotations

import dataclasses
import json

import pytest

from analysis.measures.sweep_manifest import AdaptiveRecord, Session, SweepManifest

# a manifest as a search leaves it (keys in the order the runner writes them), with a
# session that had warm states and job files, then another that did not get that far
SEARCH = {
    "sweep": {"sweep": {"name": "seed-modes", "params": {
        "ego.speed_mps": {"normal": [3.6, 0.25]}}}, "base": "../seed-rare.toml"},
    "base_scenario": {"ego": {"speed_mps": 3.6}},
    "plan_sha256": "ab" * 32,
    "runs": 40,
    "samples": 40,
    "versions": {"python": "3.11.9", "ray": None},
    "traffic_model": "SUMO's own lanes",
    "sumo_config": [],
    "controllers": {"seed": {"form": "builtin", "name": "seed"}},
    "files": {"/a/net.xml": {"field": "road.net_file", "sha256": "cd" * 32}},
    "git": None,
    "started_at": "2025-01-01T00:00:00+00:00",
    "ended_at": "2025-01-01T00:01:00+00:00",
    "status": "complete",
    "counts": {"ok": 40, "error": 0, "timeout": 0, "missing": 0},
    "collisions": 2,
    "sessions": [
        {"started_at": "2025-01-01T00:00:00+00:00", "ended_at": "2025-01-01T00:00:30+00:00",
         "executor": "local", "workers": 2, "traces": "failures", "runs_to_do": 40,
         "warm_states": {"distinct": 0, "computed": 0, "failed": []},
         "files": {"/a/net.xml": {"field": "road.net_file", "sha256": "cd" * 32}}},
        {"started_at": "2025-01-01T00:00:40+00:00", "ended_at": "2025-01-01T00:01:00+00:00",
         "executor": "ray", "workers": 8, "traces": "none", "runs_to_do": 0}],
    "adaptive": {"mode": "search", "controller": "seed", "max_runs": 40, "batch_size": 20,
                 "target_rhw": None, "score": "gap", "elite_fraction": 0.1, "stop_after": None},
    "warm_states": 0,
    "outcomes": {"completed": 38, "collided": 2, "stuck": 0, "unfinished": 0},
}
# an older version's: fewer keys, one this version does not know, in another order
OLD = {"runs": 4, "sweep": {"sweep": {"name": "old"}}, "status": "complete",
       "retired": {"kept": [1, 2]}, "sessions": [{"started_at": "x", "host": "h"}]}


def _text(plain: dict) -> str:
    return json.dumps(plain, indent=2) + "\n"  # as sdc.batch.sweeps.manifest writes it


@pytest.mark.parametrize("plain", [SEARCH, OLD, {}], ids=["search", "old", "empty"])
def test_a_manifest_read_and_written_back_is_byte_identical(plain):
    manifest = SweepManifest.from_dict(json.loads(_text(plain)))
    assert _text(manifest.to_dict()) == _text(plain)
    assert SweepManifest.from_dict(manifest.to_dict()) == manifest


def test_readers_see_attributes():
    manifest = SweepManifest.from_dict(SEARCH)
    assert manifest.sweep_name == "seed-modes"
    assert manifest.sweep_params == {"ego.speed_mps": {"normal": [3.6, 0.25]}}
    assert (manifest.runs, manifest.status, manifest.collisions) == (40, "complete", 2)
    assert isinstance(manifest.adaptive, AdaptiveRecord)
    assert (manifest.adaptive.mode, manifest.adaptive.score) == ("search", "gap")
    assert manifest.adaptive.target_rhw is None
    assert all(isinstance(s, Session) for s in manifest.sessions)
    assert manifest.session.executor == "ray" and manifest.session.warm_states is None
    old = SweepManifest.from_dict(OLD)  # what it lacks reads None
    assert old.sweep_params == {} and old.adaptive is None and old.traffic_model is None
    assert old.sumo_config is None and old.session.started_at == "x"


def test_changes_are_new_records_placed_as_a_dicts_update_places_them():
    plain = {key: value for key, value in SEARCH.items()
             if key not in ("warm_states", "outcomes", "adaptive")}
    manifest = SweepManifest.from_dict(plain)
    with pytest.raises(dataclasses.FrozenInstanceError):
        manifest.status = "running"
    changed = manifest.with_session(ended_at="later", warm_states={"distinct": 1}).updated(
        ended_at="later", counts={}, outcomes={"completed": 1}, status="interrupted")
    expected = json.loads(json.dumps(plain))
    expected["sessions"][-1].update(ended_at="later", warm_states={"distinct": 1})
    expected.update(ended_at="later", counts={}, outcomes={"completed": 1},
                    status="interrupted")
    assert _text(changed.to_dict()) == _text(expected)
    assert _text(manifest.to_dict()) == _text(plain)  # the one read is untouched
    with pytest.raises(TypeError, match="no field 'colisions'"):
        manifest.updated(colisions=1)


def test_a_new_record_is_written_in_the_order_given():
    session = Session.new(started_at="t", ended_at=None, executor="local", workers=1,
                          traces="none", runs_to_do=3)
    assert list(session.to_dict()) == ["started_at", "ended_at", "executor", "workers",
                                       "traces", "runs_to_do"]
    manifest = SweepManifest.new(sweep={"sweep": {"name": "n"}}, status="running",
                                 sessions=()).updated(sessions=(session,))
    assert manifest.to_dict() == {"sweep": {"sweep": {"name": "n"}}, "status": "running",
                                  "sessions": [session.to_dict()]}
    with pytest.raises(TypeError):
        Session.new(host="h")
