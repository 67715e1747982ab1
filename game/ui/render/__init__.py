"""All pygame drawing, by what it draws; :class:`Renderer` composes the parts for the app.

- :mod:`.camera`: the third-person camera and the frame's one projection;
- :mod:`.still`: the ground and the town's boxes painted once while the camera stands still;
- :mod:`.world`: sky, ground, the town's lines on the ground and shadows (the world around the actors);
- :mod:`.town`: the town's obstacles as boxes; :mod:`.occlusion`: what hides what from the
  camera, and the fade of a box in front of the player;
- :mod:`.actors`: the zombies, the avatar, the balls;
- :mod:`.effects`: particles, hit flashes, the red vignette of a hurt player;
- :mod:`.hud`, :mod:`.minimap`, :mod:`.plots`, :mod:`.screens`, :mod:`.board`: the HUD, the
  town from above, the live sensor plots, the menus' titles and panels, the Board setup's pictures;
- :mod:`.palette` and :mod:`.sprites`: the colours, and the pre-rendered glows, shadows,
  panels and text they all draw with.

The renderer only reads the arena's data (:mod:`game.world.arena_model`) and the
posed :class:`game.body.avatar.Avatar`; the arena itself is duck-typed (``player``,
``zombies``, ``balls``, ``held``, ``settings``, ``town``), so this package never imports
the game logic.

Screen axes are the renderer's business: the camera looks along its own +z
(depth), x to the right, y up; pixels run x right, y down. World frame: x east,
y north, z up, metres (ARCHITECTURE.md).
"""

from .renderer import Renderer

__all__ = ["Renderer"]
