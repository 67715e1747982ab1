"""Builds EnergyBall; on request compiles its hot path with mypyc.

``ENERGYBALL_COMPILE=1 pip install -e .`` compiles the modules listed under
``[tool.energyball] compiled`` in pyproject.toml (the tracker's per-sample path
and the game logic of each frame) into C extensions that sit beside their
sources and are imported instead of them. The source stays the only
implementation: mypyc compiles the same type-annotated Python. Without the
variable EnergyBall is pure Python. README, "The compiled build", says when it
is worth it and how to go back.
"""

import os
import sys
import tomllib
from pathlib import Path

from setuptools import setup
from setuptools.command.build_ext import build_ext
from setuptools.errors import CCompilerError, CompileError, LinkError

COMPILE = os.environ.get("ENERGYBALL_COMPILE", "") == "1"
# Translate to C only for a build, not for the metadata steps pip runs first.
BUILD = COMPILE and bool({"bdist_wheel", "editable_wheel", "build_ext"} & set(sys.argv))
HERE = Path(__file__).resolve().parent


def compiled_modules() -> list[str]:
    """The source files to compile, from pyproject.toml."""
    with open(HERE / "pyproject.toml", "rb") as f:
        return tomllib.load(f)["tool"]["energyball"]["compiled"]


def extensions() -> list:
    """The mypyc extensions: mypy type-checks the modules, then mypyc writes their C.

    Other modules are read for their types only (their own type errors are not
    this build's business), and a library without type information counts as Any.
    """
    from mypyc.build import mypycify

    os.chdir(HERE)  # mypycify takes paths relative to the project
    return mypycify(["--follow-imports=silent", "--ignore-missing-imports", *compiled_modules()],
                    opt_level="3")


class BuildExt(build_ext):
    """Says what the compiled build needs when the C compiler fails."""

    def build_extensions(self) -> None:
        try:
            super().build_extensions()
        except (CCompilerError, CompileError, LinkError) as e:
            raise SystemExit(
                f"error: the compiled build needs a C compiler and the Python headers (Debian: "
                f"sudo apt install gcc python3-dev), and compiling failed: {e}\n"
                "Without ENERGYBALL_COMPILE=1 EnergyBall installs as pure Python.") from None


setup(
    cmdclass={"build_ext": BuildExt},
    ext_modules=extensions() if BUILD else [],
    setup_requires=["mypy>=1.11", "numpy>=1.24"] if COMPILE else [],  # numpy: for its types
)
