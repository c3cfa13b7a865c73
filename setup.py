"""The compiled per-step code (the car's kernels, the world's);
everything else about the package is in pyproject.toml.

``-ffp-contract=off`` keeps every product rounded on its own, as numpy rounds it,
so the compiled code equals its numpy references bit for bit.
"""

from setuptools import Extension, setup

FLAGS = ["-O2", "-ffp-contract=off"]

HEADERS = ["scenarios/_buffers.h"]

setup(ext_modules=[Extension("sdc._kernels", ["sdc/_kernels.c"], depends=HEADERS,
                             extra_compile_args=FLAGS),
                   Extension("scenarios._kernels", ["scenarios/_kernels.c"], depends=HEADERS,
                             extra_compile_args=FLAGS)])
