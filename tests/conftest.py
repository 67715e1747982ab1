"""Shared test set-up: no display, no audio device, deterministic hypothesis."""

import os

from hypothesis import settings

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

settings.register_profile("deterministic", derandomize=True, deadline=None)
settings.load_profile("deterministic")


def pytest_collection_modifyitems(items: list) -> None:
    """The compiled build's file first: it runs the suite again on its own workers, the longest file by
    far, so it starts while the others' workers still have files to run (README, "Tests")."""
    items.sort(key=lambda item: item.path.name != "test_compiled_build.py")
