"""Builds the compiled kernel (prsxy_post/kernel/*.pyx) when a C compiler is there.

Everything else is in pyproject.toml. The extension is optional: where it cannot be
compiled (no compiler, no Python headers) the package installs without it and runs
the numpy reference kernel, which ``prsxy-post --version`` names and the command
line warns about. Flags: -O2, and -ffp-contract=off so no multiply and add are fused
(numpy rounds each; a fused one would not give the same bits); never -march=native
or -ffast-math (both change results from one machine to another).
"""

from __future__ import annotations

import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math"]


class OptionalBuildExt(build_ext):
    """build_ext that reports a failed compilation and carries on without it."""

    def run(self) -> None:
        try:
            super().run()
        except Exception as e:  # any failure: install the pure kernel
            self._skip(e)

    def build_extension(self, ext: Extension) -> None:
        try:
            super().build_extension(ext)
        except Exception as e:
            self._skip(e)

    @staticmethod
    def _skip(e: Exception) -> None:
        sys.stderr.write(
            f"prsxy-post: the compiled kernel was not built ({e}); "
            "installing the pure numpy kernel (slower)\n"
        )


def extensions() -> list[Extension]:
    try:
        import Cython
        from Cython.Build import cythonize
    except ImportError as e:
        sys.stderr.write(f"prsxy-post: Cython is missing ({e}); installing the pure kernel\n")
        return []
    mods = [
        Extension(
            f"prsxy_post.kernel.{name}",
            [f"prsxy_post/kernel/{name}.pyx"],
            extra_compile_args=FLAGS,
            define_macros=[("PRSXY_CYTHON_VERSION", f'"{Cython.__version__}"')],
        )
        for name in ("_ik", "_text")
    ]
    try:
        # the generated C goes under build/, not beside the package (nor into wheels)
        return list(
            cythonize(
                mods,
                compiler_directives={"language_level": 3},
                quiet=True,
                build_dir="build/cython",
            )
        )
    except Exception as e:
        sys.stderr.write(f"prsxy-post: the kernel did not cythonize ({e}); pure kernel\n")
        return []


setup(ext_modules=extensions(), cmdclass={"build_ext": OptionalBuildExt})
