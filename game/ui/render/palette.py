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
TOWN_EDGE: Colour = (255, 70, 160)  # the town's edge on the ground, a glowing line
TOWN_EDGE_DIM: Colour = (170, 60, 130)
KERB: dict[str, Colour] = {"street": (150, 235, 255), "alley": (130, 100, 210), "square": (255, 130, 210)}
KERB_DIM: dict[str, Colour] = {"street": (60, 120, 160), "alley": (80, 60, 140), "square": (150, 70, 140)}
CENTRE_LINE: Colour = (235, 190, 90)  # a street's dashed middle
KIND_COLOURS: dict[str, tuple[Colour, Colour]] = {  # the town's obstacles: fill, edge (neon)
    "building": ((30, 28, 62), (80, 210, 240)),
    "ruin": ((46, 32, 54), (200, 90, 160)),
    "wall": ((56, 36, 56), (220, 100, 130)),
    "fence": ((30, 44, 56), (110, 190, 160)),
    "car": ((54, 36, 40), (255, 150, 70)),
    "lamp_post": ((44, 44, 66), (170, 170, 210)),
}
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
MAP_LOTS = (30, 32, 62, 215)  # the minimap: the lots (pavements, yards, empty plots), translucent
MAP_OPEN: dict[str, Colour] = {"street": (62, 72, 118), "alley": (48, 52, 92), "square": (84, 66, 118)}
MAP_OBSTACLE: Colour = (4, 4, 12)
MAP_BORDER: Colour = (120, 150, 220)
MAP_ZOMBIE: Colour = (255, 70, 50)
MAP_BALL: Colour = (120, 210, 255)
MAP_PLAYER: Colour = (255, 236, 120)

TEXT: Colour = (236, 238, 246)
DIM_TEXT: Colour = (170, 176, 196)
ACCENT: Colour = (110, 210, 255)

ADD = pygame.BLEND_RGB_ADD
MULT = pygame.BLEND_RGB_MULT
SUB = pygame.BLEND_RGB_SUB


def lerp(a: Sequence[float], b: Sequence[float], t: float) -> Colour:
    """The colour a fraction ``t`` of the way from ``a`` to ``b``."""
    return (int(a[0] + (b[0] - a[0]) * t), int(a[1] + (b[1] - a[1]) * t), int(a[2] + (b[2] - a[2]) * t))
