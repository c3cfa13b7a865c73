"""Which kernels run: a compiled extension where it was built, else its numpy twin.

The extensions (``scenarios/scene/_road_kernels.c``, ``sdc/car/_geometry_kernels.c``)
are optional: built without a C compiler, sdc runs their numpy twins, which give
the same results bit for bit. The environment variable ``SDC_KERNELS`` chooses:
unset (or empty) the compiled code where it was built, ``numpy`` the numpy twins
even where it was, ``compiled`` the compiled code or an error where it was not
built. Each kernel module reads it once, when it is imported.
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType

from scenarios.common.errors import SdcError

ENV_VAR = "SDC_KERNELS"
NUMPY, COMPILED = "numpy", "compiled"


def kernel_choice() -> str:
    """``SDC_KERNELS``'s value (``""``, ``numpy`` or ``compiled``); another is an error."""
    choice = os.environ.get(ENV_VAR, "")
    if choice not in ("", NUMPY, COMPILED):
        raise SdcError(f"{ENV_VAR}: {choice!r} is neither {NUMPY!r} nor {COMPILED!r} "
                       "(unset: the compiled kernels where they were built)")
    return choice


def compiled_extension(name: str) -> ModuleType | None:
    """The compiled extension module ``name``, or ``None`` where the numpy twins run
    (it was not built, or ``SDC_KERNELS=numpy``)."""
    choice = kernel_choice()
    if choice == NUMPY:
        return None
    try:
        return importlib.import_module(name)
    except ImportError as error:
        if choice == COMPILED:
            raise SdcError(f"{ENV_VAR}=compiled: {name} was not built ({error})") from error
        return None
