"""Which modules run compiled, and whether any compiled one is out of date.

``ENERGYBALL_COMPILE=1 pip install -e .`` (setup.py) puts a C extension beside
each hot module's source, and Python imports the extension instead of the
source. Edit that source afterwards and the old compiled code still runs: this
module finds such stale extensions so that the program can say so. README,
"The compiled build".
"""

from __future__ import annotations

import importlib.machinery
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent  # the folder holding the tracker and game packages
PACKAGES = ("tracker", "game")
REBUILD = ("rebuild with `ENERGYBALL_COMPILE=1 .venv/bin/pip install -e .`, or go back to pure "
           "Python with `rm -f *.so tracker/*.so tracker/fusion/*.so game/*/*.so`")


def _extensions(root: Path) -> dict[str, Path]:
    """Module name -> its extension file, for every extension module in our packages."""
    suffixes = sorted(importlib.machinery.EXTENSION_SUFFIXES, key=len, reverse=True)  # ".so" last
    found = {}
    for package in PACKAGES:
        for path in (root / package).rglob("*"):
            suffix = next((s for s in suffixes if path.name.endswith(s)), None)
            if suffix:
                parts = path.relative_to(root).with_name(path.name[:-len(suffix)]).parts
                found[".".join(parts)] = path
    return found


def modules(root: Path = ROOT) -> list[str]:
    """The modules that run compiled, sorted (empty: pure Python)."""
    return sorted(_extensions(root))


def stale(root: Path = ROOT) -> list[str]:
    """Source files (relative to ``root``) changed after their extension was built."""
    out = []
    for name, ext in sorted(_extensions(root).items()):
        source = ext.with_name(name.rsplit(".", 1)[-1] + ".py")
        if source.exists() and source.stat().st_mtime > ext.stat().st_mtime:
            out.append(str(source.relative_to(root)))
    return out


def warn_if_stale(root: Path = ROOT) -> None:
    """In a source checkout: warn once when compiled code is older than its source."""
    if not (root / "pyproject.toml").exists():
        return  # an installed copy: sources and extensions come together from one build
    changed = stale(root)
    if changed:
        warnings.warn(f"{', '.join(changed)} changed after it was compiled, and the old compiled "
                      f"code is what runs: {REBUILD}", StaleBuildWarning, stacklevel=2)


class StaleBuildWarning(UserWarning):
    """A compiled module is older than its source."""
