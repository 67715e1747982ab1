"""Shared test set-up: no display, no audio device, deterministic hypothesis."""

import os

from hypothesis import settings

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

settings.register_profile("deterministic", derandomize=True, deadline=None)
settings.load_profile("deterministic")
