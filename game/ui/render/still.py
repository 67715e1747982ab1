"""The still camera's picture: the ground and the town's boxes painted once, used again while the camera stands still.

A frame is painted far to near (the painter's algorithm, :meth:`Renderer._order
<game.ui.render.renderer.Renderer._order>`): the ground, then before each box
of the town the things it covers (shadows, actors, light), the box, and after
the last box what no box covers. While the camera has not moved since the
last frame and no box fades, the ground and the boxes look the same, so
:class:`StillView` keeps them as one picture and paints a frame as: the
picture; then slot by slot (a slot: a box's place in the paint order), what
goes before box ``s``, and over the rectangles that painted, the boxes from
``s`` on again, blitted from the slot's cover: those boxes alone, painted in
order on a colour key. That is the same frame pixel for pixel: at a pixel
whose last box is ``b``, box ``b`` paints over whatever went before it (in
the picture and in every cover up to its slot), and what comes after it
paints over box ``b``.

The picture is built at the second frame from the same camera pose (one
painting of the ground and the boxes), each cover when a frame first needs
it (the boxes up to the next cover built, then that cover; one a frame, the
frame painted in full while any it needs is missing); all are dropped
when the camera moves. The covers kept take at most ``BUDGET_BYTES``, the
least lately used dropped first; a frame whose covers alone would take more
is painted in full.
"""

from __future__ import annotations

from typing import Callable

import pygame

COLORKEY = (255, 0, 255)  # no box is painted in this colour
BUDGET_BYTES = 48 * 2 ** 20  # the covers kept take at most this much memory


def paint_items(surface: pygame.Surface, items: list) -> list[pygame.Rect]:
    """Paint (paint function, payload) items in order; returns the rectangles they painted."""
    rects: list[pygame.Rect] = []
    for paint, payload in items:
        rects += paint(surface, payload)
    return rects


def union(rects: list[pygame.Rect], bounds: pygame.Rect) -> pygame.Rect:
    """The rectangle round ``rects`` (those with an area), within ``bounds``; empty if there are none."""
    rects = [r for r in rects if r.width and r.height]
    if not rects:
        return pygame.Rect(0, 0, 0, 0)
    return rects[0].unionall(rects[1:]).clip(bounds)


class StillView:
    """The still picture and its covers (see the module's docstring) for one camera pose."""

    def __init__(self, budget_bytes: int = BUDGET_BYTES) -> None:
        self.budget_bytes = budget_bytes
        self.key: tuple | None = None  # the last frame's camera pose and town
        self.picture: pygame.Surface | None = None
        self.covers: dict[int, tuple[pygame.Surface, pygame.Rect]] = {}  # slot: cover and where it goes, last used last
        self._boxes: list = []  # the boxes' paint items, far to near
        self._painted: list[pygame.Rect] = []  # for each slot, the rectangle round what its box paints
        self._reach: list[pygame.Rect] = []  # for each slot, the rectangle round what the boxes from it on paint
        self._scratch: pygame.Surface | None = None  # where covers are painted

    def paint(self, surface: pygame.Surface, key: tuple | None, paint_ground: Callable[[pygame.Surface], None],
              shadows: list, boxes: list, buckets: list) -> bool:
        """Paint a planned frame from the still picture if the camera has not moved since the last frame.

        ``key``: the camera's pose and the town (None while a box fades);
        ``paint_ground`` paints the ground; ``shadows`` are blits on the
        ground; ``boxes`` the boxes' (paint, payload) far to near;
        ``buckets[s]`` what goes before box ``s`` (the last, after every box).
        Returns False, painting nothing, when the frame must be painted as usual.
        """
        if key is None or key != self.key:
            self.key, self.picture, self.covers = key, None, {}
            return False
        picture = self.picture or self._build(surface, paint_ground, boxes)
        slots = [s for s, items in enumerate(buckets[:-1]) if items] + ([0] if shadows else [])
        if not self._make_covers(surface, slots):
            return False
        surface.blit(picture, (0, 0))
        if shadows:
            self._restore(surface, 0, surface.blits(shadows) or [])
        for s, items in enumerate(buckets[:-1]):
            if items:
                self._restore(surface, s, paint_items(surface, items))
        paint_items(surface, buckets[-1])
        return True

    def _build(self, surface: pygame.Surface, paint_ground: Callable[[pygame.Surface], None],
               boxes: list) -> pygame.Surface:
        """The ground and the boxes in one picture (returned and kept), and where each box paints."""
        picture = pygame.Surface(surface.get_size(), 0, surface)
        paint_ground(picture)
        bounds = picture.get_rect()
        # gfxdraw's outlines report nothing and may round a pixel past the fill's
        rects = [union([r.inflate(4, 4) for r in paint_items(picture, [box])], bounds) for box in boxes]
        self._boxes, self._painted = boxes, rects
        self._reach = [union(rects[s:], bounds) for s in range(len(rects))]
        self.picture = picture
        return picture

    def _make_covers(self, surface: pygame.Surface, slots: list[int]) -> bool:
        """The covers of ``slots``, kept last used last, the least lately used dropped beyond the budget. One
        missing cover is built a frame (the nearest: the farther are built from it), so that no frame stalls
        building many; False while any is missing, or if those of ``slots`` alone would take more than the
        budget."""
        budget = self.budget_bytes // surface.get_bytesize()  # in pixels
        if sum(self._area(s) for s in set(slots)) > budget:
            return False
        missing = sorted(set(slots).difference(self.covers), reverse=True)
        if missing:
            self.covers[missing[0]] = self._cover(surface, missing[0])
            if len(missing) > 1:
                return False
        for s in slots:
            self.covers[s] = self.covers.pop(s)
        while sum(self._area(s) for s in self.covers) > budget:
            del self.covers[next(iter(self.covers))]
        return True

    def _area(self, slot: int) -> int:
        """The pixels of the slot's cover: the rectangle round what the boxes from it on paint."""
        at = self._reach[slot] if slot < len(self._reach) else None
        return at.width * at.height if at else 0

    def _cover(self, surface: pygame.Surface, slot: int) -> tuple[pygame.Surface, pygame.Rect]:
        """The boxes from ``slot`` on painted in order on the colour key, within the rectangle round them: those
        up to the next cover built, then that cover."""
        at = self._reach[slot] if slot < len(self._reach) else pygame.Rect(0, 0, 0, 0)
        if self._scratch is None or self._scratch.get_size() != surface.get_size():
            self._scratch = pygame.Surface(surface.get_size(), 0, surface)
        scratch = self._scratch
        scratch.fill(COLORKEY, at)  # the boxes from the slot on paint nowhere else
        nearer = min((s for s in self.covers if s > slot), default=len(self._boxes))
        paint_items(scratch, self._boxes[slot:nearer])
        if nearer < len(self._boxes):
            cover, where = self.covers[nearer]
            scratch.blit(cover, where)
        cover = scratch.subsurface(at).copy() if at.width and at.height else pygame.Surface((0, 0))
        cover.set_colorkey(COLORKEY)
        return cover, at

    def _restore(self, surface: pygame.Surface, slot: int, rects: list[pygame.Rect]) -> None:
        """The boxes from ``slot`` on painted back over ``rects`` (from the slot's cover)."""
        cover, at = self.covers[slot]
        boxes = self._painted[slot:]
        x, y = at.topleft
        blits = []
        for rect in rects:
            hits = rect.collidelistall(boxes)  # only where the rectangle meets a box's
            if hits:
                part = rect.clip(boxes[hits[0]] if len(hits) == 1 else at)
                blits.append((cover, part.topleft, part.move(-x, -y)))
        surface.blits(blits, doreturn=False)
