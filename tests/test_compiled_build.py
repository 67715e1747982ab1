"""The compiled build (README, "The compiled build"): built as a user builds it, it behaves
exactly as the pure Python source does.

The wheel is built once with ``ENERGYBALL_COMPILE=1 pip wheel`` from a copy of the sources
(so nothing lands in this checkout) and unpacked; the tests run programs against it with
``PYTHONPATH`` pointing there. Building needs a C compiler and the Python headers, and pip
must be able to fetch the build requirements (mypy, numpy, setuptools).
"""

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

from tests.unavailable import unavailable

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("tracker", "game", "setup.py", "pyproject.toml", "README.md", "LICENSE")
SUFFIX = sysconfig.get_config_var("EXT_SUFFIX")


def compiled_list() -> list[str]:
    with open(ROOT / "pyproject.toml", "rb") as f:
        return tomllib.load(f)["tool"]["energyball"]["compiled"]


def test_no_compiled_module_is_a_program():
    # A compiled module has no code for ``python -m`` to run ("No code object available"): a command
    # lives in a module that stays Python (``python -m tracker.maker_sim`` was one, README).
    mains = [m for m in compiled_list() if 'if __name__ == "__main__"' in (ROOT / m).read_text()]
    assert mains == []


def pip_wheel(src: Path, out: Path, **env: str) -> subprocess.CompletedProcess:
    """``ENERGYBALL_COMPILE=1 pip wheel`` of the sources in ``src``, into ``out``."""
    return subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(out), str(src)],
                          env={**os.environ, "ENERGYBALL_COMPILE": "1", **env}, capture_output=True, text=True)


@pytest.fixture(scope="module")
def sources(tmp_path_factory) -> Path:
    """A copy of the sources a build needs (so that nothing is built in this checkout)."""
    if shutil.which(sysconfig.get_config_var("CC").split()[0]) is None:
        unavailable("no C compiler to build the compiled build with", "install gcc")
    if not (Path(sysconfig.get_paths()["include"]) / "Python.h").exists():
        unavailable("no Python headers (Python.h) to build the compiled build with",
                    "install the Python development headers")
    src = tmp_path_factory.mktemp("compiled") / "src"
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
        else:
            src.mkdir(exist_ok=True)
            shutil.copy2(path, src / name)
    return src


@pytest.fixture(scope="module")
def build(sources) -> Path:
    """The compiled wheel, unpacked: a folder to put on PYTHONPATH (beside it, ``src``: the
    pure sources it was built from)."""
    work = sources.parent
    done = pip_wheel(sources, work / "dist")
    assert done.returncode == 0, done.stdout + done.stderr
    site = work / "site"
    (wheel,) = (work / "dist").glob("*.whl")
    zipfile.ZipFile(wheel).extractall(site)
    return site


def test_without_a_working_compiler_the_build_says_what_it_needs(sources, tmp_path):
    done = pip_wheel(sources, tmp_path, CC="/bin/false")
    assert done.returncode != 0 and not list(tmp_path.glob("*.whl"))
    assert "the compiled build needs a C compiler and the Python headers" in done.stdout + done.stderr
    assert "Without ENERGYBALL_COMPILE=1 EnergyBall installs as pure Python" in done.stdout + done.stderr


def run(path: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``python args`` with ``path`` (the compiled build, or the pure sources) first on the path."""
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy", "PYTHONPATH": str(path)}
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True)


def test_every_listed_module_is_compiled(build, tmp_path):
    expected = sorted(m[:-len(".py")].replace("/", ".") for m in compiled_list())
    assert all((build / (m.replace(".", "/") + SUFFIX)).exists() for m in expected)
    done = run(build, "-c", "from tracker import compiled; print(' '.join(compiled.modules()))", cwd=tmp_path)
    assert done.stdout.split() == expected, done.stderr


def match_report(path: Path, cwd: Path) -> dict:
    done = run(path, "-m", "game", "--headless", "--matches", "2", "--seed", "5", "--duration", "25",
               "--json", cwd=cwd)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def without_timing(report: dict) -> dict:
    return {"matches": [{k: v for k, v in m.items() if k != "timing"} for m in report["matches"]],
            "summary": {k: v for k, v in report["summary"].items() if k != "timing"}}


def test_a_compiled_match_is_the_pure_match_to_the_last_digit(build, tmp_path):
    compiled, pure = match_report(build, tmp_path), match_report(build.parent / "src", tmp_path)
    assert compiled["summary"]["timing"]["compiled"] and not pure["summary"]["timing"]["compiled"]
    assert compiled["summary"]["kills"] > 0
    assert without_timing(compiled) == without_timing(pure)


def test_the_test_suite_passes_on_the_compiled_build(build, tmp_path):
    """Everything but the firmware (no Python of ours runs there) and this file, on workers of its own
    (the options in pyproject.toml)."""
    done = run(build, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--import-mode=append",
               f"--rootdir={ROOT}", "-c", str(ROOT / "pyproject.toml"), str(ROOT / "tests"),
               f"--ignore={ROOT / 'tests' / 'firmware'}", f"--ignore={Path(__file__)}", cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert " passed" in done.stdout and "failed" not in done.stdout
