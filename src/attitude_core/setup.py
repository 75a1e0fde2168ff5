"""Build of attitude_core's compiled kernels (metadata in pyproject.toml).

``kernels/_kernels.pyx`` is compiled ahead of time to a C extension when the package is
installed (tools/bootstrap), so no process pays a compile at start-up. IEEE double
without floating-point contraction and with libm's own pow, so the kernels round as
their Python references do.
"""

from Cython.Build import cythonize
from setuptools import Extension, setup

setup(
    ext_modules=cythonize(
        [
            Extension(
                "attitude_core.kernels._kernels",
                ["attitude_core/kernels/_kernels.pyx"],
                extra_compile_args=[
                    "-O2",
                    "-ffp-contract=off",
                    "-fno-fast-math",
                    "-fno-builtin-pow",
                ],
            )
        ],
        compiler_directives={"language_level": "3"},
    )
)
