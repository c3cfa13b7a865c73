"""The compiled per-step code (the car's kernels, the world's, and the SUMO step);
everything else about the package is in pyproject.toml.

``-ffp-contract=off`` keeps every product rounded on its own, as numpy rounds it,
so the compiled code equals its numpy references bit for bit.
"""

from setuptools import Extension, setup

FLAGS = ["-O2", "-ffp-contract=off"]

HEADERS = ["scenarios/_buffers.h", "scenarios/_traffic_box.h"]

setup(ext_modules=[Extension("sdc._kernels", ["sdc/_kernels.c"], depends=HEADERS,
                             extra_compile_args=FLAGS),
                   Extension("scenarios._kernels", ["scenarios/_kernels.c"], depends=HEADERS,
                             extra_compile_args=FLAGS),
                   Extension("scenarios._sumo_step", ["scenarios/_sumo_step.cpp"],
                             depends=HEADERS, language="c++", libraries=["dl"],
                             extra_compile_args=[*FLAGS, "-std=c++17"])])
