"""``sdc settle``: watch a scenario's traffic warm up and suggest its warm-up."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import click

from scenarios.common.errors import SdcError, SpecError
from scenarios.common.seeding import SEED_LIMIT
from scenarios.spec.toml_io import load_spec
from sdc.cli.common import (
    a_number,
    bad_input,
    check_spec_inputs,
    exit_interrupted,
    progress_bar,
    set_option,
)


@click.command()
@click.argument("spec_file", metavar="SPEC.toml", type=click.Path(path_type=Path))
@click.option("--for", "watch_s", type=click.FloatRange(20, 3600), default=600.0,
              show_default=True, metavar="SECONDS", callback=a_number,
              help="How long to watch the traffic warm up [simulated s].")
@click.option("--seed", type=click.IntRange(0, SEED_LIMIT - 1),
              help="The warm-up's seed (default: the spec's traffic.warm_seed, else "
                   "scenario.seed).")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), metavar="FILE.png",
              help="The plot [default: <scenario name>-settling.png here]; the series "
                   "beside it as FILE.csv.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the suggestion as one JSON object on the last line.")
@set_option("scenario")
def settle(spec_file: Path, watch_s: float, seed: int | None, out: Path | None,
           as_json: bool, overrides: tuple[str, ...]) -> None:
    """Watch a scenario's traffic warm up and suggest traffic.warm_up_s (on a
    sumo_config road: traffic.enter_s, on the configuration's clock).

    SUMO runs the scenario's background traffic alone (no ego, no obstacles) for
    --for seconds, recording every simulated second the vehicles in the network,
    their mean speed and how many halt. A warm-up truncation rule (MSER on batch
    means of one correlation length, e.g. one signal cycle: analysis/stats/settling.py)
    reads off when each measure settled; the suggestion is the latest, rounded up
    to 10 s. When a measure may still be changing (the rule's cut lands at the end
    of the first half of the watch), no value is suggested, only a lower bound:
    watch longer. A drift that starts late in the watch goes unseen: watch at
    least twice the warm-up you expect.
    """
    import pandas as pd

    from analysis.report.settling_report import settling_figure
    from analysis.stats.settling import suggest_warm_up_s
    from scenarios.sumo_net.road_source import road_source
    from scenarios.world_backends import settling_series

    if out is not None and out.suffix != ".png":
        bad_input(f"--out: {out} must end in .png (the series goes beside it as .csv)")
    if out is not None and not out.parent.is_dir():
        bad_input(f"--out: directory {out.parent} does not exist")
    try:
        spec = load_spec(spec_file, overrides)
        if not spec.scenario.world_backend.warm_states:
            raise SpecError("scenario.backend", "sdc settle watches SUMO's traffic; "
                            f"the spec's backend is {spec.scenario.backend!r}")
        traffic = spec.traffic
        if not road_source(spec.road).has_traffic(traffic):
            raise SpecError("traffic", "the scenario has no background traffic to watch "
                            "(traffic.flow_vph_per_lane and traffic.vehicles are 0)")
        if seed is not None:
            spec = dataclasses.replace(spec, traffic=dataclasses.replace(spec.traffic,
                                                                         warm_seed=seed))
        check_spec_inputs(spec, spec_file, overrides)
        with progress_bar("warming up", total=watch_s) as update:
            series = settling_series(spec, watch_s, on_sample=update)
    except SdcError as e:
        bad_input(str(e))
    except KeyboardInterrupt:
        exit_interrupted("interrupted")
    frame = pd.DataFrame(series)
    suggestion = suggest_warm_up_s(frame)
    # a configuration's warm-up runs on SUMO's clock to traffic.enter_s
    field = road_source(spec.road).warm_up_field
    current_s = getattr(spec.traffic, field)
    out = out or Path(f"{spec.scenario.name}-settling.png")
    out.write_bytes(settling_figure(frame, suggestion, f"{spec.scenario.name}: traffic "
                                    "warming up", current_warm_up_s=current_s,
                                    field=f"traffic.{field}"))
    frame.to_csv(out.with_suffix(".csv"), index=False)
    for line in settle_lines(suggestion, current_s, f"traffic.{field}"):
        click.echo(line)
    click.echo(f"plot: {out}; the series: {out.with_suffix('.csv')}")
    if as_json:
        click.echo(json.dumps(suggestion))


def settle_lines(suggestion: dict, current_s: float,
                 field: str = "traffic.warm_up_s") -> list[str]:
    """What ``sdc settle`` prints: each measure's settling time and the suggestion for
    ``field`` (``traffic.enter_s`` on a configuration's clock)."""
    lines = [f"{name}: settled after {m['truncation_s']:.0f} s"
             if m["settled"] else f"{name}: still changing" for name, m in
             suggestion["measures"].items()]
    if suggestion["settled"]:
        lines.append(f"suggested {field} = {suggestion['warm_up_s']:.0f} "
                     f"({suggestion['rule']}; the spec has {current_s:g})")
    else:
        lines.append(f"not settled within {suggestion['observed_s']:.0f} s: {field} of at "
                     f"least {suggestion['warm_up_at_least_s']:.0f}; watch longer (--for)")
    return lines
