"""The compiled per-step kernels; everything else about the package is in pyproject.toml.

``-ffp-contract=off`` keeps every product rounded on its own, as numpy rounds it,
so the kernels equal their numpy references bit for bit.
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension("sdc._kernels", ["sdc/_kernels.c"],
                             extra_compile_args=["-O2", "-ffp-contract=off"])])
