"""The one exception hierarchy of sdc: every error a user can cause by input."""

from __future__ import annotations

from pathlib import Path


class SdcError(Exception):
    """Base of every error sdc raises on purpose."""


class SpecError(SdcError):
    """An input value is wrong; ``field`` is its path (``obstacles[0].lane``) and
    ``file``, when known, the file it came from (the message then starts with it)."""

    def __init__(self, field: str, message: str, file: str | Path | None = None):
        self.field = field
        self.message = message
        self.file = None if file is None else str(file)
        text = f"{field}: {message}" if field else message
        super().__init__(f"{self.file}: {text}" if self.file is not None else text)

    def in_file(self, file: str | Path) -> SpecError:
        """This error naming the file it came from (unchanged if it names one)."""
        return self if self.file is not None else SpecError(self.field, self.message, file)


class OptionError(SpecError):
    """A command-line option's value is wrong (``--set ego.sped_mps=9``): the message
    starts with the option as given, and names no file (the option, not the file it
    changes, is at fault)."""

    def in_file(self, file: str | Path) -> OptionError:
        return self


class FileError(SpecError):
    """A file that cannot be used: missing, a directory, unreadable, not in its
    format, truncated, or written by another sdc version. The message starts with
    the file's path and says what is wrong."""

    def __init__(self, path: str | Path, problem: str):
        super().__init__("", problem, path)
