"""The one exception hierarchy of sdc: every error a user can cause by input."""


class SdcError(Exception):
    """Base of every error sdc raises on purpose."""


class SpecError(SdcError):
    """An input value is wrong; ``field`` is its path (``obstacles[0].lane``)."""

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}" if field else message)
