"""A sweep's plan: every sample's values (drawn by its sampler, a grid, or as given)
under every controller, one :class:`PlannedRun` each with its spec and seed, seated
in shared worlds; the plan's digest.

The plan is a pure function of the sweep: the same file gives the same runs, specs
and seeds in any process.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from scenarios.common.errors import SpecError
from scenarios.common.seeding import POINTS_STREAM, RUN_SEEDS_STREAM, draw_seeds, stream_rng
from scenarios.spec.controller_ref import controller_label
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.sweep_params import set_path
from scenarios.spec.sweep_spec import SweepSpec, warm_seeds
from scenarios.spec.world_seating import WorldSeat, group_worlds

#: how often planning says how far it got [runs]
PLAN_PROGRESS_RUNS = 1000


@dataclasses.dataclass(frozen=True)
class PlannedRun:
    """One run of a sweep. ``spec`` is None when the sample makes an invalid scenario;
    ``error`` then says why, with the sample's values."""

    index: int  # position in the plan
    run_id: str
    sample: int
    controller: str  # its label (scenarios.spec.controller_ref.controller_label)
    seed: int
    backend: str
    params: dict[str, Any]
    spec: ScenarioSpec | None
    error: str | None
    world: WorldSeat | None = None  # its seat in a shared world ([sweep] egos_per_world)


def _unit_points(sweep: SweepSpec, rng: np.random.Generator) -> np.ndarray:
    n, d = sweep.samples, len(sweep.params)
    if d == 0:
        return np.zeros((n, 0))
    if sweep.sampler == "random":
        return rng.random((n, d))
    from scipy.stats import qmc  # only the quasi-random samplers need scipy

    if sweep.sampler == "sobol":
        with warnings.catch_warnings():  # balance properties want 2**k points; any n works
            warnings.simplefilter("ignore", UserWarning)
            return qmc.Sobol(d, scramble=True, rng=rng).random(n)
    return qmc.LatinHypercube(d, rng=rng).random(n)


def sample_values(sweep: SweepSpec) -> list[dict[str, Any]]:
    """Each sample's parameter values, in plan order."""
    if sweep.given is not None:
        return [dict(values) for values in sweep.given.values]
    point_rng = stream_rng(sweep.seed, POINTS_STREAM)
    if sweep.sampler == "grid":
        axes = [p.grid(sweep.levels) for p in sweep.params]
        return [{p.path: v for p, v in zip(sweep.params, combo, strict=True)}
                for combo in itertools.product(*axes)]
    return [{p.path: p.at(float(u)) for p, u in zip(sweep.params, row, strict=True)}
            for row in _unit_points(sweep, point_rng)]


def expand(sweep: SweepSpec, progress: Callable[[int, int], None] | None = None
           ) -> list[PlannedRun]:
    """The plan: every sample under every controller, each sample with its own seed;
    ``progress(runs planned, runs in all)`` is called as it goes (every
    :data:`PLAN_PROGRESS_RUNS` runs, and at the end).

    A sample's seed is ``scenario.seed`` for all its controllers (a paired
    comparison), unless ``scenario.seed`` is itself a swept parameter.
    """
    samples = sample_values(sweep)
    return plan_samples(sweep, samples,
                        draw_seeds(stream_rng(sweep.seed, RUN_SEEDS_STREAM), len(samples)),
                        progress=progress)


def plan_samples(sweep: SweepSpec, samples: list[dict[str, Any]], seeds: list[int], *,
                 first_sample: int = 0, index_width: int | None = None,
                 controllers: tuple[str, ...] | None = None,
                 progress: Callable[[int, int], None] | None = None) -> list[PlannedRun]:
    """The runs of ``samples`` (parameter values, one dict each) under ``controllers``
    (default: the sweep's), sample ``i`` numbered ``first_sample + i`` and seeded
    ``seeds[i]``. Run IDs are ``<sample, zero-padded to index_width>-<controller>``;
    ``progress``: as for :func:`expand`."""
    controllers = sweep.controllers if controllers is None else controllers
    last = first_sample + len(samples) - 1
    width = index_width or max(5, len(str(last)))
    base_plain = sweep.base.to_plain()
    warm = warm_seeds(sweep)
    plan = []
    total = len(samples) * len(controllers)
    for i, (values, seed) in enumerate(zip(samples, seeds, strict=True), start=first_sample):
        if progress is not None and len(plan) % PLAN_PROGRESS_RUNS < len(controllers):
            progress(len(plan), total)
        shown = ", ".join(f"{k}={v!r}" for k, v in values.items())
        spec, error = None, None
        if sweep.given is not None:
            try:
                plain = sweep.given.scenario_of(values).to_plain()
            except SpecError as e:
                plain, error = json.loads(json.dumps(base_plain)), (
                    f"invalid scenario from sample {i} ({shown}): {e}")
        else:
            plain = json.loads(json.dumps(base_plain))  # a deep copy of plain data
        set_path(plain, "scenario.seed", int(seed))
        if warm is not None:  # the sample's warm state: one of the sweep's, by its seed
            set_path(plain, "traffic.warm_seed", warm[int(values.get("scenario.seed", seed))
                                                      % len(warm)])
        controller_values = {}  # each controller takes those it has (ControllerSpec.renamed)
        for path, value in values.items() if sweep.given is None else ():
            if path.startswith("controller.") and path != "controller.name":
                controller_values[path.removeprefix("controller.")] = value
            else:
                set_path(plain, path, value)
        try:
            spec = None if error else ScenarioSpec.from_plain(plain)
        except SpecError as e:
            error = f"invalid scenario from sample {i} ({shown}): {e}"
        for controller in controllers:
            label = controller_label(controller)
            run_spec, run_error = None, error
            if spec is not None:
                try:
                    run_spec = dataclasses.replace(
                        spec, controller=spec.controller.renamed(controller, controller_values))
                except SpecError as e:
                    run_error = f"invalid scenario from sample {i} ({shown}): {e}"
            plan.append(PlannedRun(
                index=first_sample * len(controllers) + len(plan),
                run_id=f"{i:0{width}d}-{label}", sample=i, controller=label,
                seed=int(plain["scenario"]["seed"]),
                backend=str(plain["scenario"].get("backend", "sumo")), params=values,
                spec=run_spec, error=run_error,
            ))
    if progress is not None:
        progress(len(plan), total)
    return _seated(plan, sweep.egos_per_world, sweep.runs_per_world, width)


def _seated(plan: list[PlannedRun], egos_per_world: int, runs_per_world: int, width: int
            ) -> list[PlannedRun]:
    """``plan`` with its runs seated in shared worlds (:func:`group_worlds`), each
    run's spec taking its world's traffic seed; unchanged for one ego a world. Only
    SUMO holds several egos, and only a network road places them apart: a run swept
    onto another backend or a built road keeps a world of its own."""
    if egos_per_world == 1:
        return plan
    grouped = group_worlds([(k, f"{run.sample:0{width}d}", run.controller, run.spec)
                            for k, run in enumerate(plan)
                            if run.spec is not None
                            and run.spec.scenario.world_backend.holds_several_egos
                            and run.spec.road.on_network],
                           runs_per_world, egos_per_world)
    return [run if k not in grouped else
            dataclasses.replace(run, spec=grouped[k][1], world=grouped[k][0])
            for k, run in enumerate(plan)]


def plan_sha256(plan: list[PlannedRun]) -> str:
    """A digest of everything that decides the runs' results."""
    digest = hashlib.sha256()
    for run in plan:
        body = run.spec.to_plain() if run.spec else run.error
        seat = [] if run.world is None else [run.world.world_id, run.world.slot]
        digest.update(json.dumps([run.run_id, run.params, body, *seat], sort_keys=True).encode())
    return digest.hexdigest()
