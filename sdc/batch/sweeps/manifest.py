"""Provenance of a sweep directory: ``manifest.json`` and the versions behind it."""

from __future__ import annotations

import datetime
import hashlib
import json
import platform
import subprocess
from importlib import metadata
from pathlib import Path

from analysis.measures.sweep_manifest import MANIFEST_FILE, RESUME_KEYS, SweepManifest
from scenarios.common.atomic_write import write_atomic
from scenarios.common.errors import SdcError
from scenarios.common.file_read import read_json, require_keys
from scenarios.spec.controller_ref import controller_label
from sdc.car.controller_plugins import controller_source

_PACKAGES = ("sdc", "libsumo", "eclipse-sumo", "numpy", "scipy", "pandas", "pyarrow", "ray")


def now_iso() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def package_versions() -> dict[str, str | None]:
    """Python's and every result-relevant package's version (None: not installed)."""
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def git_state() -> dict | None:
    """The commit of the source tree sdc runs from, when it is a git checkout."""
    source = Path(__file__).resolve().parents[2]  # sdc/
    try:
        commit = subprocess.run(["git", "-C", str(source), "rev-parse", "HEAD"],
                                capture_output=True, text=True, timeout=10, check=True)
        status = subprocess.run(["git", "-C", str(source), "status", "--porcelain"],
                                capture_output=True, text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": commit.stdout.strip(), "dirty": bool(status.stdout.strip())}


def controller_sources(names) -> dict[str, dict]:
    """Each controller's label and where its code comes from (a plug-in's file with
    its sha256: ``sdc.car.controller_plugins.controller_source``)."""
    return {controller_label(name): controller_source(name) for name in names}


def controller_changes(manifest: SweepManifest) -> list[str]:
    """One line per plug-in controller whose file is gone or differs from the one
    the sweep recorded (manifests without controllers: none)."""
    lines = []
    for label, recorded in (manifest.controllers or {}).items():
        if not isinstance(recorded, dict) or "sha256" not in recorded:
            continue
        try:
            now = controller_source(recorded["name"])
        except SdcError as e:
            lines.append(f"the controller {label} cannot be loaded now ({e})")
            continue
        if now.get("sha256") != recorded["sha256"]:
            lines.append(f"the controller {label} changed since the sweep ran: "
                         f"{recorded.get('file')} had sha256 {recorded['sha256'][:12]}..., "
                         f"now {str(now.get('sha256'))[:12]}...")
    return lines


def network_file_changes(manifest: SweepManifest) -> list[str]:
    """One line per network file (``road.net_file``) of the sweep that is gone or
    differs from the bytes its runs ran on (manifests without files: none)."""
    lines = []
    for path, recorded in (manifest.files or {}).items():
        if not isinstance(recorded, dict) or recorded.get("field") != "road.net_file":
            continue
        try:
            now = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        except OSError as e:
            lines.append(f"the network file {path} cannot be read now ({e.strerror or e})")
            continue
        if now != recorded.get("sha256"):
            lines.append(f"the network file {path} changed since the sweep ran: it had "
                         f"sha256 {str(recorded.get('sha256'))[:12]}..., now {now[:12]}...")
    return lines


def read_manifest(out_dir: Path) -> SweepManifest | None:
    """``out_dir``'s manifest, None when it has none; one that cannot be read or was
    written by another sdc version is a :class:`~scenarios.common.errors.FileError`."""
    path = Path(out_dir) / MANIFEST_FILE
    if not path.exists():
        return None
    return SweepManifest.from_dict(require_keys(read_json(path, "the sweep manifest"),
                                                RESUME_KEYS, path, "the sweep manifest"))


def write_manifest(out_dir: Path, manifest: SweepManifest) -> None:
    """Write atomically, so a kill never leaves half a manifest."""
    text = json.dumps(manifest.to_dict(), indent=2) + "\n"
    write_atomic(Path(out_dir) / MANIFEST_FILE, lambda tmp: tmp.write_text(text))
