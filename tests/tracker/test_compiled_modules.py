"""tracker.compiled: which modules run compiled, and which compiled ones are stale."""

import importlib.machinery
import os
import warnings

from tracker import compiled

SUFFIX = importlib.machinery.EXTENSION_SUFFIXES[0]  # this Python's own, e.g. ".cpython-311-x86_64-linux-gnu.so"


def make(root, name, source_mtime, extension_mtime):
    """A module ``name`` (dotted) with its source and a (fake) extension, at these mtimes."""
    path = root.joinpath(*name.split("."))
    path.parent.mkdir(parents=True, exist_ok=True)
    source, ext = path.with_suffix(".py"), path.with_name(path.name + SUFFIX)
    source.write_text("x = 1\n")
    ext.write_bytes(b"\x7fELF")
    os.utime(source, (source_mtime, source_mtime))
    os.utime(ext, (extension_mtime, extension_mtime))


def test_extensions_are_found_and_an_edited_source_is_stale(tmp_path):
    make(tmp_path, "tracker.fusion.default", 1000, 2000)  # built after its source: fine
    make(tmp_path, "game.world.arena", 3000, 2000)  # edited after the build: stale
    (tmp_path / "tracker" / "plain.py").write_text("y = 2\n")  # never compiled
    assert compiled.modules(tmp_path) == ["game.world.arena", "tracker.fusion.default"]
    assert compiled.stale(tmp_path) == [os.path.join("game", "world", "arena.py")]


def test_a_pure_checkout_has_no_compiled_modules(tmp_path):
    (tmp_path / "tracker").mkdir()
    (tmp_path / "tracker" / "quat.py").write_text("z = 3\n")
    assert compiled.modules(tmp_path) == [] and compiled.stale(tmp_path) == []


def test_a_stale_checkout_warns_with_the_way_out(tmp_path):
    make(tmp_path, "tracker.lowpass", 3000, 2000)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        compiled.warn_if_stale(tmp_path)  # not a checkout (an installed copy): never stale
        (tmp_path / "pyproject.toml").write_text("")
        compiled.warn_if_stale(tmp_path)
    assert [w.category for w in caught] == [compiled.StaleBuildWarning]
    message = str(caught[0].message)
    assert "tracker/lowpass.py" in message and "ENERGYBALL_COMPILE=1" in message
