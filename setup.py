"""The compiled per-step code (the car's geometry kernels and the world's road kernels);
everything else about the package is in pyproject.toml.

Both extensions are optional: without a C compiler the build skips them (with a
warning) and sdc runs their numpy twins (``scenarios/scene/road_kernels.py``,
``sdc/car/geometry_kernels.py``; ``SDC_KERNELS=numpy`` forces them), which give the
same results bit for bit. ``-ffp-contract=off`` keeps every product rounded on its
own, as numpy rounds it, which is what makes the two paths equal.
"""

from setuptools import Extension, setup

FLAGS = ["-O2", "-ffp-contract=off"]
HEADERS = ["scenarios/scene/_buffers.h", "scenarios/scene/_polyline.h"]


def kernel(name: str, source: str) -> Extension:
    return Extension(name, [source], depends=HEADERS, extra_compile_args=FLAGS, optional=True)


setup(ext_modules=[kernel("sdc.car._geometry_kernels", "sdc/car/_geometry_kernels.c"),
                   kernel("scenarios.scene._road_kernels", "scenarios/scene/_road_kernels.c")])
