"""Reading the files sdc is given, so that every way one can fail (missing, a
directory, unreadable, not UTF-8, not in its format, truncated, written by
another sdc version) is one :class:`FileError` whose message starts with the
file's path and says what is wrong. ``what`` names the file in the message
(``"the scenario file"``).
"""

from __future__ import annotations

import gzip
import hashlib
import json
import os
import stat
import zlib
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from scenarios.common.errors import FileError

if TYPE_CHECKING:
    import pyarrow as pa


def _open_problem(error: OSError | ValueError) -> str:
    if isinstance(error, ValueError):  # an embedded NUL byte
        return "not a valid path"
    if isinstance(error, FileNotFoundError | NotADirectoryError):
        return "no such file"
    if isinstance(error, IsADirectoryError):
        return "it is a directory, not a file"
    if isinstance(error, PermissionError):
        return "permission denied"
    return error.strerror or str(error)


def check_file(path: str | Path, what: str) -> Path:
    """``path`` if it names a regular file, else a :class:`FileError`."""
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError) as e:
        raise FileError(path, f"cannot read {what}: {_open_problem(e)}") from None
    if stat.S_ISDIR(mode):
        raise FileError(path, f"cannot read {what}: it is a directory, not a file")
    if not stat.S_ISREG(mode):
        raise FileError(path, f"cannot read {what}: not a regular file")
    return path


def read_bytes(path: str | Path, what: str) -> bytes:
    path = check_file(path, what)
    try:
        return path.read_bytes()
    except (OSError, ValueError) as e:
        raise FileError(path, f"cannot read {what}: {_open_problem(e)}") from None


GZIP_MAGIC = b"\x1f\x8b"


def sha256_hex(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def file_sha256(path: str | Path) -> str:
    """The sha256 of the file at ``path`` (hex)."""
    return sha256_hex(Path(path).read_bytes())


def unzipped(path: str | Path, data: bytes, what: str) -> bytes:
    """``data`` (the bytes of ``path``) gunzipped when they are gzip's, as SUMO reads
    a ``.gz`` file (or any file whose bytes are gzip's) and a plain one alike."""
    if not data.startswith(GZIP_MAGIC):
        return data
    try:
        return gzip.decompress(data)
    except (OSError, EOFError, zlib.error) as e:
        raise FileError(path, f"{what} is gzip-compressed but cannot be unpacked "
                              f"({_first_line(e)})") from None


def read_text(path: str | Path, what: str) -> str:
    """The file as UTF-8 text."""
    data = read_bytes(path, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise FileError(path, f"{what} is not UTF-8 text (byte 0x{data[e.start]:02x} at "
                              f"offset {e.start})") from None


def read_json(path: str | Path, what: str) -> Any:
    text = read_text(path, what)
    try:
        return json.loads(text)
    except (json.JSONDecodeError, RecursionError) as e:
        raise FileError(path, f"{what} is not valid JSON ({e})") from None


def _first_line(error: Exception) -> str:
    return str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__


def read_parquet(path: str | Path, what: str, *, required: Iterable[str] = (),
                 schema: pa.Schema | None = None, optional: pa.Schema | None = None
                 ) -> pa.Table:
    """The Parquet file's table. A column of ``required`` that it lacks is an error
    (a file of another sdc version); with ``schema``, the table has exactly its
    columns, in its order and cast to its types, then those of ``optional`` the file
    has (a column added since older files were written)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = check_file(path, what)
    needed = list(schema.names if schema is not None else required)
    try:
        with pq.ParquetFile(path) as file:
            names = file.schema_arrow.names
            missing = [name for name in needed if name not in names]
            if missing:
                more = f" and {len(missing) - 4} more" if len(missing) > 4 else ""
                raise FileError(path, f"{what} is from another sdc version (no column "
                                      f"{', '.join(missing[:4])}{more})")
            table = file.read()
    except (OSError, pa.ArrowException) as e:
        raise FileError(path, f"{what} is not a Parquet file, or is truncated "
                              f"({_first_line(e)})") from None
    if schema is None:
        return table
    if optional is not None:
        schema = pa.schema([*schema, *(f for f in optional if f.name in table.column_names)])
    try:  # the file's metadata kept
        return table.select(schema.names).cast(schema.with_metadata(table.schema.metadata))
    except (pa.ArrowException, ValueError) as e:
        raise FileError(path, f"{what} is from another sdc version ({_first_line(e)})") from None


def require_keys(data: Any, keys: dict[str, Any], path: str | Path, what: str) -> dict:
    """``data`` if it is a mapping holding each of ``keys`` with a value of its type
    (a dotted key looks inside nested mappings), else a :class:`FileError`."""
    if not isinstance(data, dict):
        raise FileError(path, f"{what} is from another sdc version (not a JSON object)")
    for dotted, kind in keys.items():
        node: Any = data
        for part in dotted.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        if not isinstance(node, kind) or isinstance(node, bool) and kind is not bool:
            name = getattr(kind, "__name__", str(kind))
            raise FileError(path, f"{what} is from another sdc version (no {dotted} of type "
                                  f"{name})")
    return data
