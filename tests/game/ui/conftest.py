"""What the pygame tests share: a display under SDL's dummy driver."""

import os

import pygame
import pytest


@pytest.fixture(scope="module")
def screen():
    """A 1280x720 display (SDL's dummy video driver: no window), for one test module."""
    os.environ["SDL_VIDEODRIVER"] = "dummy"
    pygame.display.init()
    pygame.font.init()
    surface = pygame.display.set_mode((1280, 720))
    yield surface
    pygame.display.quit()
