"""A SUMO configuration (``.sumocfg``) as a run uses it: its network, route files and
additional files, resolved as SUMO resolves them (comma or space separated lists,
paths relative to the configuration's folder, gzipped or not), its begin time, and
its other options.

What a run takes from it (:data:`APPLIED_SECTIONS`): the input files, the begin
time, and the options of its processing, routing and random-number sections, as
command-line options, but those a run sets itself (:data:`OVERRIDDEN`: its end,
step length, teleporting, seed, collisions, lane changes). Outputs, reports and
GUI settings are not applied. :meth:`SumoConfig.manifest` says which options were
overridden and which left out.

A configuration travels as one :class:`ConfigBundle`: its files' bytes under fixed
names beside a description, one zip a job ships to its workers; the sha256 of its
content identifies the whole configuration (for warm states). A run writes the
bundle's files into its scratch folder, so whatever the demand's additional files
write lands there. A process packs a configuration file once while it is unchanged
(the files it names are not watched).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import io
import json
import math
import re
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

from scenarios.common.errors import FileError, SpecError
from scenarios.common.file_read import read_bytes, unzipped
from scenarios.sumo_net.build import input_path, process_problem

FIELD = "road.config_file"
#: the sections whose options a run applies (their files and begin aside)
APPLIED_SECTIONS = ("processing", "routing", "random_number", "mesoscopic")
#: options a run sets itself, whatever the configuration says
OVERRIDDEN = ("end", "step-length", "time-to-teleport", "seed", "random", "collision.action",
              "lanechange.duration", "lateral-resolution", "step-method.ballistic",
              "no-step-log", "no-warnings")
_INPUT_FILES = ("net-file", "route-files", "additional-files")
_BUNDLE_DESCRIPTION = "sdc-config.json"
#: the file name a bundle takes on a worker, after the configuration's stem
BUNDLE_SUFFIX = ".sdc-config.zip"
_ZIP_TIME = (2020, 1, 1, 0, 0, 0)  # fixed, so equal configurations make equal bundles
#: a bundle's format: bumped when what it holds changes
BUNDLE_FORMAT = 2


def seconds(text: str) -> float | None:
    """A SUMO time in seconds: ``12.5`` or a clock time ``[D:]H:M:S`` (None: neither)."""
    try:
        parts = [float(part) for part in text.split(":")]
    except ValueError:
        return None
    if len(parts) not in (1, 3, 4):
        return None
    return sum(part * unit for part, unit in zip(reversed(parts), (1, 60, 3600, 86_400),
                                                    strict=False))


def _file_list(value: str) -> list[str]:
    """SUMO's list of files: separated by commas or spaces."""
    return [item for item in re.split(r"[,\s]+", value.strip()) if item]


@dataclasses.dataclass(frozen=True)
class SumoConfig:
    """A configuration read from its file; paths are absolute."""

    path: Path
    net_file: Path
    route_files: tuple[Path, ...]
    additional_files: tuple[Path, ...]
    begin_s: float
    options: dict[str, dict[str, str]]  # section -> option -> value, files and begin aside

    def applied_options(self) -> dict[str, str]:
        """The options a run passes to SUMO (see the module)."""
        return {name: value for section in APPLIED_SECTIONS
                for name, value in self.options.get(section, {}).items()
                if name not in OVERRIDDEN}

    def manifest(self) -> dict:
        """What the manifest says of the configuration: its file, the options a run
        applies, overrides and leaves out."""
        every = {name: value for section in self.options.values()
                 for name, value in section.items()}
        applied = self.applied_options()
        return {"file": str(self.path), "begin_s": self.begin_s, "applied": applied,
                "overridden": {name: every[name] for name in OVERRIDDEN if name in every},
                "not_applied": sorted(name for name in every
                                      if name not in applied and name not in OVERRIDDEN)}


def _options(root: ET.Element, path: Path) -> dict[str, dict[str, str]]:
    options: dict[str, dict[str, str]] = {}
    for section in root:
        if not isinstance(section.tag, str):
            continue  # a comment
        for option in section:
            if not isinstance(option.tag, str):
                continue
            value = option.get("value")
            if value is None:
                raise FileError(path, f"the SUMO configuration's <{option.tag}> has no value")
            options.setdefault(section.tag, {})[option.tag] = value
    return options


def _existing(config: Path, name: str, option: str) -> Path:
    path = (config.parent / name).resolve()
    if not path.is_file():
        raise FileError(config, f"its {option} {name!r} is not a file ({path})")
    return path


def read_config(path: str | Path) -> SumoConfig:
    """The configuration in ``path``: a missing or unreadable file, one that is not a
    SUMO configuration, has no network or names a file that is not there is a
    :class:`FileError` naming the file."""
    path = Path(path).resolve() if Path(path).exists() else Path(path)
    data = read_bytes(path, "the SUMO configuration")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as e:
        raise FileError(path, f"the SUMO configuration is not well-formed XML ({e})") from None
    if root.tag not in ("sumoConfiguration", "configuration"):
        raise FileError(path, f"is not a SUMO configuration (root element <{root.tag}>)")
    options = _options(root, path)
    inputs = options.pop("input", {})
    files = {option: _file_list(inputs.pop(option, "")) for option in _INPUT_FILES}
    if inputs:
        options["input"] = inputs
    if not files["net-file"]:
        raise FileError(path, "the SUMO configuration names no network (net-file)")
    if len(files["net-file"]) > 1:
        raise FileError(path, "the SUMO configuration names more than one network")
    begin_s = seconds(options.get("time", {}).pop("begin", "0"))
    if begin_s is None:
        raise FileError(path, "the SUMO configuration's begin is not a time")
    return SumoConfig(
        path, _existing(path, files["net-file"][0], "net-file"),
        tuple(_existing(path, f, "route file") for f in files["route-files"]),
        tuple(_existing(path, f, "additional file") for f in files["additional-files"]),
        begin_s, options)


@dataclasses.dataclass(frozen=True)
class ConfigBundle:
    """A configuration's files under fixed names (``files``: name -> bytes) and what
    a run needs of it (``description``): the names of the network, route and
    additional files in order, and its manifest (its begin, the options applied).
    ``sha256`` identifies the content (the description and every file)."""

    description: dict
    files: dict[str, bytes]

    @functools.cached_property
    def sha256(self) -> str:
        h = hashlib.sha256(json.dumps(self.description, sort_keys=True).encode())
        for name in sorted(self.files):
            h.update(f"\n{name}\n{len(self.files[name])}\n".encode())
            h.update(self.files[name])
        return h.hexdigest()

    def to_bytes(self) -> bytes:
        """The bundle as one zip file (equal bundles, equal bytes)."""
        out = io.BytesIO()
        with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as z:
            z.writestr(zipfile.ZipInfo(_BUNDLE_DESCRIPTION, _ZIP_TIME),
                       json.dumps(self.description, sort_keys=True))
            for name in sorted(self.files):
                z.writestr(zipfile.ZipInfo(name, _ZIP_TIME), self.files[name])
        return out.getvalue()

    @property
    def net_name(self) -> str:
        return self.description["net"]

    @property
    def begin_s(self) -> float:
        return self.description["manifest"]["begin_s"]

    def write(self, folder: Path) -> dict[str, Path]:
        """Write the files into ``folder``; their paths by name."""
        paths = {}
        for name, data in self.files.items():
            paths[name] = folder / name
            paths[name].parent.mkdir(parents=True, exist_ok=True)
            paths[name].write_bytes(data)
        return paths

    def sumo_arguments(self, paths: dict[str, Path], own_routes: Path | None,
                       fresh: bool = True, set_already: list[str] = ()) -> list[str]:
        """SUMO's command-line arguments for the configuration, written at ``paths``,
        with ``own_routes`` (the ego's and the obstacles' types, routes and vehicles)
        after its additional files (SUMO reads those whole at its start, route files
        as the time comes); ``fresh``: starting at its begin (not from a saved state,
        which holds its time). Its options named in ``set_already`` (command-line
        arguments) are left to those."""
        d = self.description
        additional = [str(paths[name]) for name in d["additional"]]
        if own_routes is not None:
            additional.append(str(own_routes))
        arguments = ["--net-file", str(paths[d["net"]])]
        if fresh:
            arguments += ["--begin", repr(self.begin_s)]
        if d["routes"]:
            arguments += ["--route-files", ",".join(str(paths[name]) for name in d["routes"])]
        if additional:
            arguments += ["--additional-files", ",".join(additional)]
        for name, value in sorted(d["manifest"]["applied"].items()):
            if f"--{name}" not in set_already:
                arguments += [f"--{name}", value]
        return arguments


def _bundle_name(kind: str, index: int, path: Path) -> str:
    return f"{kind}/{index:02d}-{path.name}"


def pack(config: SumoConfig) -> ConfigBundle:
    """The bundle of ``config`` (its files read now)."""
    files: dict[str, bytes] = {}

    def add(kind: str, index: int, path: Path, what: str) -> str:
        name = _bundle_name(kind, index, path)
        files[name] = read_bytes(path, what)
        return name

    description = {
        "format": BUNDLE_FORMAT,
        "net": add("net", 0, config.net_file, "the SUMO network"),
        "routes": [add("routes", i, p, "a route file") for i, p in enumerate(config.route_files)],
        "additional": [add("additional", i, p, "an additional file")
                       for i, p in enumerate(config.additional_files)],
        "manifest": {**config.manifest(), "file": config.path.name},
    }
    return ConfigBundle(description, files)


def is_bundle(data: bytes) -> bool:
    return data[:4] == b"PK\x03\x04"


def unpack(data: bytes, path: Path) -> ConfigBundle:
    """A bundle from its zip's bytes (read from ``path``, named in errors)."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            description = json.loads(z.read(_BUNDLE_DESCRIPTION))
            files = {name: z.read(name) for name in z.namelist() if name != _BUNDLE_DESCRIPTION}
    except (zipfile.BadZipFile, KeyError, ValueError) as e:
        raise FileError(path, f"is not an sdc configuration bundle ({e})") from None
    if description.get("format") != BUNDLE_FORMAT:
        raise FileError(path, "is a configuration bundle of another sdc version")
    return ConfigBundle(description, files)


def load_bundle(path: str | Path) -> ConfigBundle:
    """The bundle of the configuration at ``path``: a ``.sumocfg`` (packed now), or a
    bundle a job shipped. Any problem is a :class:`SpecError` naming
    ``road.config_file``. A process packs the same unchanged configuration once."""
    path = input_path(str(path))
    try:
        stat = path.stat()
    except (OSError, ValueError):
        stat = None
    try:
        if stat is None:
            read_bytes(path, "the SUMO configuration")  # raises, naming the problem
        return _load(path, stat.st_mtime_ns, stat.st_size)
    except SpecError as e:
        raise SpecError(FIELD, str(e)) from None


def config_step_s(config_file: str) -> float | None:
    """The step length the configuration at ``config_file`` asks for, in seconds (None:
    it asks none, and SUMO's default would be 1 s)."""
    asked = load_bundle(config_file).description["manifest"]["overridden"].get("step-length")
    return None if asked is None else seconds(asked)


#: where a run's step length came from, in a manifest's ``step_from``
STEP_FROM_CONFIG, STEP_FROM_SPEC = "the configuration's step-length", "scenario.step_s"


def config_manifest(config_file: str, step_s: float) -> dict:
    """What a manifest records of the configuration a ``sumo_config`` road names
    (``config_file``, as the spec names it): its file, begin, the run's step
    (``step_s``) and where it came from
    (:data:`STEP_FROM_CONFIG` where it is the one the configuration asks for, else
    :data:`STEP_FROM_SPEC`), and the options a run applies, overrides, leaves out (the
    step length among the overridden ones only where the run's differs)."""
    manifest = load_bundle(config_file).description["manifest"]
    overridden, applied = dict(manifest["overridden"]), dict(manifest["applied"])
    from_config = config_step_s(config_file) == step_s
    if from_config:
        applied["step-length"] = overridden.pop("step-length")
    return {**manifest, "file": config_file, "applied": applied, "overridden": overridden,
            "step_s": step_s, "step_from": STEP_FROM_CONFIG if from_config else STEP_FROM_SPEC}


@functools.lru_cache(maxsize=4)
def _load(path: Path, mtime_ns: int, size: int) -> ConfigBundle:
    data = read_bytes(path, "the SUMO configuration")
    return unpack(data, path) if is_bundle(data) else pack(read_config(path))


#: the demand's elements sent off at a time (their depart)
_SENT_AT = ("vehicle", "trip", "person", "container")
#: the demand's elements that send a stream off (until their end)
_FLOWS = ("flow", "personFlow", "containerFlow")


def _last_of(element: ET.Element) -> float | None:
    """When a demand element last sends something off or surely holds something
    standing on the road (None: not one, or triggered by another): a vehicle's or a
    trip's stops hold it at least to their ``until``, or their ``duration`` after its
    depart (it reaches them later), and for good where a person or a container
    triggers them; a flow with neither an end nor a number and a fixed period never
    stops (inf)."""
    if element.tag in _SENT_AT:
        depart = seconds(element.get("depart", ""))
        if depart is None:
            return None
        return max([depart, *(_stands_until(stop, depart) for stop in element.iter("stop"))])
    if element.tag not in _FLOWS:
        return None
    begin = seconds(element.get("begin", "0")) or 0.0
    if element.get("end") is not None:
        return seconds(element.get("end"))
    number, period = element.get("number"), seconds(element.get("period", ""))
    if number is not None and period is not None:
        return begin + float(number) * period
    return math.inf


def _stands_until(stop: ET.Element, depart_s: float) -> float:
    """How long a stop surely holds a vehicle that departed at ``depart_s`` [s]."""
    if stop.get("triggered", "false") not in ("false", "0") or \
            stop.get("containerTriggered", "false") not in ("false", "0"):
        return math.inf
    until = seconds(stop.get("until", ""))
    duration = seconds(stop.get("duration", ""))
    return max(until if until is not None else -math.inf,
               depart_s + duration if duration is not None else -math.inf)


def last_departure_s(bundle: ConfigBundle) -> float | None:
    """When the configuration's demand last sends something off or surely holds
    something standing (a vehicle's or a trip's depart or the end of its stops, a
    flow's end; departures triggered by others aside: :func:`_last_of`), None when
    nothing departs."""
    latest = None
    for name in (*bundle.description["routes"], *bundle.description["additional"]):
        data = unzipped(Path(name), bundle.files[name], "a route file")
        for _, element in ET.iterparse(io.BytesIO(data)):
            if element.tag == "stop":  # read with its vehicle, which clears it
                continue
            last = _last_of(element)
            if last is not None:
                latest = last if latest is None else max(latest, last)
            element.clear()
    return latest


@functools.lru_cache(maxsize=16)
def _last_departure_of(sha256: str, path: str) -> float | None:
    """:func:`last_departure_s` of the bundle of ``path`` whose content is ``sha256``,
    read once a process."""
    return last_departure_s(load_bundle(path))


def check_enter_s(path: str | Path, enter_s: float) -> None:
    """``enter_s`` before the configuration's begin, or past its demand's last
    departure, is bad input naming ``traffic.enter_s``; a demand that sends nothing off
    names ``road.config_file``. Cheap after its first call: each run checks it before
    SUMO simulates anything."""
    bundle = load_bundle(path)
    begin_s = bundle.begin_s
    if enter_s < begin_s:
        raise SpecError("traffic.enter_s", f"{enter_s} is before the configuration's begin "
                        f"({begin_s:g} s)")
    latest = _last_departure_of(bundle.sha256, str(path))
    if latest is None:
        raise SpecError(FIELD, f"{path}: the configuration's demand sends no vehicle off")
    if enter_s > latest:
        raise SpecError("traffic.enter_s", f"{enter_s} is past the end of the configuration's "
                        f"demand (its last departure, or the end of the last stop that surely "
                        f"holds a vehicle, is at {latest:g} s): past it nothing of the demand is "
                        "sure to be on the road (what departed last may have arrived)")


def check_config(path: str | Path, enter_s: float) -> None:
    """Bad input before any run: a configuration SUMO cannot load (a
    :class:`SpecError` naming ``road.config_file``), or an ``enter_s`` it cannot take
    (:func:`check_enter_s`)."""
    check_enter_s(path, enter_s)
    bundle = load_bundle(path)
    problem = _sumo_load_error(bundle)
    if problem is not None:
        raise SpecError(FIELD, f"{path}: SUMO cannot load the configuration: {problem}")


#: loads a configuration in libsumo and takes one step (argv: SUMO's arguments)
_LOAD_ONE_STEP = ("import sys, libsumo; libsumo.start(['sumo', *sys.argv[1:]]); "
                  "libsumo.simulationStep(); libsumo.close()")


def _sumo_load_error(bundle: ConfigBundle) -> str | None:
    """What goes wrong when SUMO loads the configuration and takes its first step
    (None: nothing); in a process of its own (SUMO crashes on some inputs)."""
    import subprocess
    import sys
    import tempfile

    with tempfile.TemporaryDirectory(prefix="sdc-config-") as folder:
        paths = bundle.write(Path(folder))
        proc = subprocess.run([sys.executable, "-c", _LOAD_ONE_STEP,
                               *bundle.sumo_arguments(paths, None), "--no-step-log", "true",
                               "--no-warnings", "true"],
                              capture_output=True, text=True, check=False, cwd=folder)
    return process_problem(proc)
