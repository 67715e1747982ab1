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


setup(
    ext_modules=extensions() if BUILD else [],
    setup_requires=["mypy>=1.11", "numpy>=1.24"] if COMPILE else [],  # numpy: for its types
)
