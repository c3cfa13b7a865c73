"""A sweep directory's ``manifest.json``, typed: :class:`SweepManifest`, its
:class:`Session` records and a search's or estimate's :class:`AdaptiveRecord`.

The sweep runner writes it (``sdc.batch.sweeps.sweep_runner``: new, a session starts, its
warm states and job files, the end) and the report reads it; both see attributes,
never string keys. Every record is frozen: a change is a new record
(:meth:`Record.updated`, which places a key the file did not hold after the others,
as a dict's update does). :meth:`Record.from_dict` reads any manifest, an older
version's too: a key it lacks reads None and stays out of the file, a key this
version does not know is kept; so :meth:`Record.to_dict` gives back the very dict
read, in its order, and the file written is byte for byte what a plain dict made.

This module is the one home of the manifest's keys: the records' fields, the keys a
reader requires (:data:`READ_KEYS`, :data:`RESUME_KEYS`, spelled through
:meth:`Record.key`, so a renamed field breaks them at import) and the keys of the sweep
file's plain form the manifest is read by (:class:`SweepFileKey`); and of the names of the
sweep directory's files and folders (:class:`SweepDir`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, ClassVar


class SweepDir:
    """A sweep directory's files and folders, by name (``DIR/<name>``): the one home of
    the names the sweep runner writes and ``sdc replay``, ``sdc export`` and the report
    read. A search's or estimate's own file: ``analysis.rare.adaptive_summary.summary_path``."""

    manifest = "manifest.json"  # what the sweep is and how far it got (SweepManifest)
    plan = "plan.parquet"  # the planned runs, each with its spec
    plan_parts = "plan-parts"  # a search's or estimate's plan as it grows, batch by batch
    results = "results.parquet"  # one row per run, once consolidated
    parts = "parts"  # the rows as runs finish, before they are consolidated
    traces = "traces"  # the kept traces, <run_id>.parquet (--traces failures or all)


#: the sweep directory's file
MANIFEST_FILE = SweepDir.manifest
#: the plan's column that holds each run's spec, as JSON (its others are the result
#: row's, by their names: ``analysis.measures.row_columns.RowCol``)
PLAN_SPEC_COLUMN = "spec_json"


class SweepFileKey:
    """The keys of a sweep file's plain form (``scenarios.spec.sweep_spec.SweepSpec.to_plain``,
    the manifest's ``sweep``) that the manifest is read by."""

    sweep = "sweep"  # its [sweep] table
    name = "name"
    egos_per_world = "egos_per_world"  # only when above 1
    params = "params"  # path -> distribution


@dataclasses.dataclass(frozen=True, kw_only=True)
class Record:
    """A JSON object as typed fields, its key order and its unknown keys kept."""

    _order: tuple[str, ...] = dataclasses.field(default=(), repr=False)
    _unknown: Mapping[str, Any] = dataclasses.field(default_factory=dict, repr=False)
    #: fields that hold records: name -> (record class, a list of them?)
    _NESTED: ClassVar[dict[str, tuple[type[Record], bool]]] = {}

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The keys this version knows, in the order a new record writes them."""
        return tuple(f.name for f in dataclasses.fields(cls) if not f.name.startswith("_"))

    @classmethod
    def key(cls, field: str, *within: str) -> str:
        """The dotted path of ``field`` (a key this version knows) and the keys ``within``
        its value, as :func:`scenarios.common.file_read.require_keys` takes it; a field
        this version does not know is a TypeError, where the path is spelled."""
        cls._check({field: None})
        return ".".join((field, *within))

    @classmethod
    def new(cls, **fields):
        """A record of ``fields``, written in the order given."""
        cls._check(fields)
        return cls(**fields, _order=tuple(fields))

    @classmethod
    def from_dict(cls, plain: Mapping[str, Any]):
        """The record of a dict read from JSON (any version's)."""
        known = cls.names()
        return cls(**{key: cls._typed(key, value) for key, value in plain.items()
                      if key in known},
                   _order=tuple(plain),
                   _unknown={key: value for key, value in plain.items() if key not in known})

    def to_dict(self) -> dict[str, Any]:
        """The dict :meth:`from_dict` read, or :meth:`new` made, with every change."""
        return {key: self._unknown[key] if key in self._unknown else _plain(getattr(self, key))
                for key in self._order}

    def updated(self, **changes):
        """This record with ``changes``; a key it did not hold goes last."""
        self._check(changes)
        return dataclasses.replace(self, **changes, _order=self._order + tuple(
            key for key in changes if key not in self._order))

    @classmethod
    def _check(cls, fields: Mapping[str, Any]) -> None:
        unknown = set(fields) - set(cls.names())
        if unknown:
            raise TypeError(f"{cls.__name__} has no field {sorted(unknown)[0]!r}")

    @classmethod
    def _typed(cls, key: str, value: Any) -> Any:
        nested, many = cls._NESTED.get(key, (None, False))
        if nested is None:
            return value
        if many:
            return (tuple(nested.from_dict(v) if isinstance(v, Mapping) else v for v in value)
                    if isinstance(value, list) else value)
        return nested.from_dict(value) if isinstance(value, Mapping) else value


def _plain(value: Any) -> Any:
    if isinstance(value, Record):
        return value.to_dict()
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


@dataclasses.dataclass(frozen=True, kw_only=True)
class Session(Record):
    """One command that ran the directory: when, on what, and what its runs read."""

    started_at: str | None = None
    ended_at: str | None = None  # None while it runs (or when it was killed)
    executor: str | None = None  # local, ray
    workers: int | None = None
    traces: str | None = None  # none, failures, all
    runs_to_do: int | None = None
    warm_states: dict | None = None  # distinct, computed, failed: the warm states it needed
    files: dict | None = None  # what travelled with its jobs: driver path -> field, sha256


@dataclasses.dataclass(frozen=True, kw_only=True)
class AdaptiveRecord(Record):
    """What a search or an estimate did beyond its sweep file (its options:
    ``sdc.batch.sweeps.adaptive_runner.AdaptiveSettings``)."""

    mode: str | None = None  # search, estimate
    controller: str | None = None  # the controller judged
    max_runs: int | None = None
    batch_size: int | None = None
    target_rhw: float | None = None  # an estimate's
    score: str | None = None  # gap, ttc
    elite_fraction: float | None = None
    stop_after: int | None = None  # a search's


@dataclasses.dataclass(frozen=True, kw_only=True)
class SweepManifest(Record):
    """What a sweep directory is and how far it got (None: the manifest does not say)."""

    sweep: dict | None = None  # the sweep file, plain (SweepSpec.to_plain)
    base_scenario: dict | None = None
    #: the --set options it was made with (PATH=VALUE, as given; None: none); its sweep
    #: and base_scenario hold their values, and a resume must give the same
    overrides: list | None = None
    plan_sha256: str | None = None  # a search's or estimate's: its settings' digest
    runs: int | None = None  # planned
    samples: int | None = None
    versions: dict | None = None  # python's and the packages'
    traffic_model: str | None = None
    sumo_config: list | None = None  # each SUMO configuration: applied, overridden, not
    controllers: dict | None = None  # label -> where its code comes from
    files: dict | None = None  # what travels with the jobs: driver path -> field, sha256
    git: dict | None = None  # commit, dirty
    started_at: str | None = None
    ended_at: str | None = None
    status: str | None = None  # running, complete, interrupted
    counts: dict | None = None  # rows by status, and missing
    collisions: int | None = None
    sessions: tuple[Session, ...] = ()
    warm_states: int | None = None  # the most distinct warm states of a session
    outcomes: dict | None = None  # ok rows by outcome
    adaptive: AdaptiveRecord | None = None  # a search's or estimate's settings
    #: how the runs shared worlds (analysis.measures.world_sharing; None: none did)
    shared_worlds: dict | None = None

    _NESTED: ClassVar[dict[str, tuple[type[Record], bool]]] = {
        "sessions": (Session, True), "adaptive": (AdaptiveRecord, False)}

    @property
    def sweep_name(self) -> str:
        return self.sweep[SweepFileKey.sweep][SweepFileKey.name]

    @property
    def egos_per_world(self) -> int:
        """The runs the sweep let share a world (``[sweep] egos_per_world``; 1: none)."""
        return int((self.sweep or {}).get(SweepFileKey.sweep, {})
                   .get(SweepFileKey.egos_per_world, 1))

    @property
    def sweep_params(self) -> dict:
        """The swept parameters as the sweep file gives them: path -> distribution."""
        return self.sweep[SweepFileKey.sweep].get(SweepFileKey.params, {})

    @property
    def session(self) -> Session:
        """The session that runs now (the last)."""
        return self.sessions[-1]

    def with_session(self, **changes) -> SweepManifest:
        """The manifest with ``changes`` to the session that runs now."""
        return self.updated(sessions=(*self.sessions[:-1], self.session.updated(**changes)))


#: what every reader of a manifest requires, with its type (the report reads no more)
READ_KEYS: dict[str, type] = {
    SweepManifest.key("sweep", SweepFileKey.sweep, SweepFileKey.name): str}
#: what resuming a sweep and replaying its runs require besides
#: (``sdc.batch.sweeps.manifest.read_manifest``)
RESUME_KEYS: dict[str, type] = {**READ_KEYS, SweepManifest.key("plan_sha256"): str,
                                SweepManifest.key("versions"): dict,
                                SweepManifest.key("sessions"): list}
