"""The renderer's colours, blend modes and the colour arithmetic they share."""

from __future__ import annotations

from typing import Sequence

import pygame

Colour = tuple[int, int, int]

SKY_TOP: Colour = (6, 8, 28)
SKY_HORIZON: Colour = (118, 58, 112)
HILLS: Colour = (38, 24, 58)
GROUND_HORIZON: Colour = (66, 42, 84)
GROUND_NEAR: Colour = (14, 16, 32)
HAZE: Colour = GROUND_HORIZON  # what distant things fade into
GRID: Colour = (70, 140, 178)  # brighter than the ground in every channel (see Scenery._build_ground)
RING: Colour = (255, 70, 160)
RING_DIM: Colour = (170, 60, 130)
SHADOW_DARKNESS = (0.45, 0.65, 0.85)  # multiply factors: dark, medium, faint

OUTLINE: Colour = (8, 10, 22)
AVATAR_BODY: Colour = (70, 130, 240)
AVATAR_LEGS: Colour = (44, 78, 160)
AVATAR_FREE_ARM: Colour = (58, 108, 206)
AVATAR_HEAD: Colour = (236, 196, 160)
AVATAR_HAIR: Colour = (92, 60, 40)
AVATAR_ARM: Colour = (255, 160, 50)  # the tracked arm

ZOMBIE_LEGS: Colour = (58, 92, 52)
ZOMBIE_BODY: Colour = (88, 140, 66)
ZOMBIE_ARMS: Colour = (112, 172, 82)
ZOMBIE_HEAD: Colour = (146, 196, 104)
ZOMBIE_EYES: Colour = (255, 70, 40)
FLYING_TINT: Colour = (170, 255, 220)  # zombies charged by a hit glow a little


GLOW_COLOURS: dict[str, Colour] = {
    "energy": (90, 190, 255),
    "spark": (255, 214, 130),
    "goo": (110, 255, 100),
    "ember": (255, 100, 50),
    "white": (230, 240, 255),
}
PALETTES = tuple(GLOW_COLOURS)  # particle palette index -> glow colour name
PALETTE_INDEX = {name: i for i, name in enumerate(PALETTES)}
AXIS_COLOURS: tuple[Colour, ...] = ((255, 96, 96), (96, 232, 112), (96, 156, 255), (255, 206, 80))
TEXT: Colour = (236, 238, 246)
DIM_TEXT: Colour = (170, 176, 196)
ACCENT: Colour = (110, 210, 255)

ADD = pygame.BLEND_RGB_ADD
MULT = pygame.BLEND_RGB_MULT
SUB = pygame.BLEND_RGB_SUB


def lerp(a: Sequence[float], b: Sequence[float], t: float) -> Colour:
    """The colour a fraction ``t`` of the way from ``a`` to ``b``."""
    return (int(a[0] + (b[0] - a[0]) * t), int(a[1] + (b[1] - a[1]) * t), int(a[2] + (b[2] - a[2]) * t))
