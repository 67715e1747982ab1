"""The Board setup's pictures: the board as a box with its axes, the faces asked, the sphere of directions.

The maker's calibrations (:mod:`game.ui.board_setup`) show the board turned
as the accelerometer sees it and the directions the magnetometer has covered
(the warm-up's bars are plain meters).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pygame

from .hud import draw_bar
from .palette import AXIS_COLOURS, DIM_TEXT, OUTLINE, TEXT, Colour
from .sprites import SpriteCache, TextCache

BOARD_FACES = ("+z", "-z", "+x", "-x", "+y", "-y")  # as tracker.accel_procedure.FACES asks them
BOARD_HALF = (1.6, 1.0, 0.22)  # the board's half-extent along its x, y, z (a flat board, x the long side)
FACE_COLOUR: Colour = (44, 72, 150)  # the board's solder mask
FACE_HIGHLIGHT: Colour = (255, 214, 90)
FACE_DONE: Colour = (110, 220, 130)
COVER_ON: Colour = (90, 230, 200)
COVER_OFF: Colour = (38, 44, 88)
LIGHT_DIR = np.array((-0.35, 0.55, 0.76)) / np.linalg.norm((-0.35, 0.55, 0.76))  # screen frame: x right, y up, z out
VIEW_PITCH = math.radians(28.0)  # the board is seen from above the horizon by this much
GLOBE_TILT = math.radians(20.0)
GLOBE_CACHE = 8  # globes kept (two a frame; more only after a resize)


class BoardPictures:
    """Draws the Board setup screen's parts (a part of :class:`~game.ui.render.Renderer`, with its text,
    sprites and globes)."""

    text: TextCache
    sprites: SpriteCache
    globes: dict[tuple, tuple]  # (radius, turn, directions) -> (globe_cells(), covered, surface)

    def draw_board(self, surface: pygame.Surface, rect, up: Sequence[float] | np.ndarray | None, title: str,
                   highlight: str | None = None, captured: Sequence[str] = (), turn: float = 0.0) -> None:
        """The sensor board as a box with its axes, turned so that the sensor-frame vector ``up`` points up.

        ``highlight``: the face drawn glowing (the face to put up next); ``captured``:
        faces drawn ticked; ``turn``: the view's slow swing about the vertical (rad),
        so the box reads as solid. Faces are named as :data:`BOARD_FACES` ("+x" = the
        sensor's x axis up). ``up`` None (no reading yet) draws the board flat.
        """
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        small = max(14, rect.height // 16)
        self.text.blit(surface, title, small, TEXT, (rect.centerx, rect.top + 6), "midtop")
        box = rect.inflate(-rect.width // 6, -rect.height // 4).move(0, small // 2)
        scale = 0.5 * min(box.width, box.height) / (max(BOARD_HALF) + 1.1)  # the arrows' tips fit
        view = board_view(np.array(up if up is not None else (0.0, 0.0, 1.0), dtype=float), turn)
        centre = np.array(box.center, dtype=float)
        toward = [float((view @ face_normal("+" + a))[2]) >= 0.0 for a in "xyz"]
        for axis in range(3):  # axes pointing away first: the box hides what is behind it
            if not toward[axis]:
                self._draw_axis(surface, view, centre, scale, axis, small)
        for face in visible_faces(view):
            corners = [_to_screen(view @ c, centre, scale) for c in face_corners(face)]
            light = 0.55 + 0.45 * max(0.0, float((view @ face_normal(face)) @ LIGHT_DIR))
            base = FACE_HIGHLIGHT if face == highlight else FACE_DONE if face in captured else FACE_COLOUR
            pygame.draw.polygon(surface, tuple(int(c * light) for c in base), corners)
            pygame.draw.polygon(surface, OUTLINE, corners, 2)
            if face == "+z":  # the IMU chip sits on the top face
                self._draw_chip(surface, view, centre, scale)
            if face == highlight and face[0] == "-":  # a + face has its axis' label at the arrow's tip
                mid = _to_screen(view @ (face_normal(face) * np.array(BOARD_HALF)), centre, scale)
                self.text.blit(surface, face, small + 4, OUTLINE, mid, "center", shadow=False)
        for axis in range(3):
            if toward[axis]:
                self._draw_axis(surface, view, centre, scale, axis, small)
        arrow_x, top = rect.left + 24, box.top + small
        self.text.blit(surface, "up", small, DIM_TEXT, (arrow_x, box.top), "midtop")
        pygame.draw.line(surface, DIM_TEXT, (arrow_x, top + 30), (arrow_x, top + 4), 2)
        pygame.draw.polygon(surface, DIM_TEXT, [(arrow_x, top), (arrow_x - 6, top + 8), (arrow_x + 6, top + 8)])

    def _draw_axis(self, surface: pygame.Surface, view: np.ndarray, centre: np.ndarray, scale: float,
                   axis: int, small: int) -> None:
        """A sensor axis as an arrow out of its + face, labelled "+x", "+y" or "+z" at the tip."""
        start, tip = np.zeros(3), np.zeros(3)
        start[axis], tip[axis] = BOARD_HALF[axis], BOARD_HALF[axis] + 0.9
        a, b = _to_screen(view @ start, centre, scale), _to_screen(view @ tip, centre, scale)
        colour = AXIS_COLOURS[axis]
        pygame.draw.line(surface, colour, a, b, 3)
        pygame.draw.circle(surface, colour, b, 5)
        dx, dy = b[0] - a[0], b[1] - a[1]
        length = math.hypot(dx, dy) or 1.0
        at = (round(b[0] + 16 * dx / length), round(b[1] + 16 * dy / length))
        self.text.blit(surface, "+" + "xyz"[axis], small, colour, at, "center")

    def _draw_chip(self, surface: pygame.Surface, view: np.ndarray, centre: np.ndarray, scale: float) -> None:
        """The IMU chip: a small dark square on the board's +z face, a dot at its pin 1."""
        hz = BOARD_HALF[2]
        chip = [np.array((x, y, hz)) for x, y in ((-0.9, -0.3), (-0.3, -0.3), (-0.3, 0.3), (-0.9, 0.3))]
        pygame.draw.polygon(surface, (24, 26, 34), [_to_screen(view @ c, centre, scale) for c in chip])
        pygame.draw.circle(surface, (220, 220, 220), _to_screen(view @ np.array((-0.8, 0.2, hz)), centre, scale), 2)

    def draw_face_chips(self, surface: pygame.Surface, rect, asked: str | None, captured: Sequence[str],
                        up: str | None, pulse: float = 0.0) -> None:
        """The six faces in the order they are asked: captured ticked green, the asked one
        glowing, the one up now outlined."""
        rect = pygame.Rect(rect)
        size = max(14, rect.height // 2)
        width = rect.width // len(BOARD_FACES)
        for i, face in enumerate(BOARD_FACES):
            chip = pygame.Rect(rect.left + i * width + 4, rect.top, width - 8, rect.height)
            glow = 0.75 + 0.25 * math.sin(pulse * 6.0)
            colour = FACE_DONE if face in captured else \
                tuple(int(c * glow) for c in FACE_HIGHLIGHT) if face == asked else (40, 46, 80)
            pygame.draw.rect(surface, colour, chip, border_radius=6)
            if face == up:
                pygame.draw.rect(surface, TEXT, chip.inflate(4, 4), 3, border_radius=8)
            ink = OUTLINE if face in captured or face == asked else DIM_TEXT
            self.text.blit(surface, face, size, ink, chip.center, "center", shadow=False)
            if face in captured:
                x, y = chip.right - 14, chip.top + 6
                pygame.draw.lines(surface, OUTLINE, False, [(x - 6, y + 5), (x - 2, y + 9), (x + 6, y)], 3)

    def draw_direction_sphere(self, surface: pygame.Surface, rect, directions: np.ndarray,
                              covered: Sequence[bool]) -> None:
        """The sphere of directions as two globes (its front and its back half), each bin lit once covered.

        ``directions``: the bins' unit vectors (n, 3), sensor frame; ``covered``: one
        flag per bin. Each pixel of a globe shows the bin whose direction is nearest
        (the cells of the bins' centres), shaded by the light.
        """
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        small = max(14, rect.height // 16)
        radius = max(8, min(rect.width // 4 - 12, rect.height // 2 - small - 16))
        for k, label in enumerate(("front", "back")):
            centre = (rect.left + rect.width * (1 + 2 * k) // 4, rect.centery + small // 2)
            globe = self._globe(radius, k * math.pi, np.asarray(directions, float), tuple(bool(c) for c in covered))
            surface.blit(globe, globe.get_rect(center=centre))
            pygame.draw.circle(surface, OUTLINE, centre, radius + 1, 2)
            self.text.blit(surface, label, small, DIM_TEXT, (centre[0], rect.top + 6), "midtop")

    def _globe(self, radius: int, turn: float, directions: np.ndarray, covered: tuple[bool, ...]) -> pygame.Surface:
        """A globe turned by ``turn`` about the vertical (:func:`globe_cells`, :func:`globe_image`) as a
        surface; its geometry is computed once, its picture again only when ``covered`` changes."""
        key = (radius, turn, directions.tobytes())
        cells, shown, globe = self.globes.get(key, (None, None, None))
        if cells is None:
            cells = globe_cells(radius, view_rotation(turn, GLOBE_TILT), directions)
            if len(self.globes) >= GLOBE_CACHE:  # a new size or new bins: the old ones go
                self.globes.clear()
        if globe is None or shown != covered:
            colours = np.array([COVER_ON if c else COVER_OFF for c in covered], dtype=float).reshape(-1, 3)
            image = globe_image(radius, cells, colours)
            globe = pygame.surfarray.make_surface(np.ascontiguousarray(image.transpose(1, 0, 2)))
            globe.set_colorkey((0, 0, 0))
        self.globes[key] = (cells, covered, globe)
        return globe

    def draw_meter(self, surface: pygame.Surface, rect, label: str, fraction: float, colour: Colour) -> None:
        """A labelled bar: the label above, the bar filled to ``fraction``."""
        rect = pygame.Rect(rect)
        size = max(14, rect.height // 2)
        self.text.blit(surface, label, size, TEXT, rect.topleft)
        draw_bar(surface, pygame.Rect(rect.left, rect.top + size + 4, rect.width, max(8, rect.height // 3)),
                 fraction, colour)

    def draw_setup_header(self, surface: pygame.Surface, title: str, steps: Sequence[str], current: int) -> None:
        """A band across the top: the title on the left, the numbered steps on the right, the current one lit."""
        w, h = surface.get_size()
        size = max(20, h // 26)
        band = pygame.Rect(0, 0, w, int(size * 2.2))
        surface.blit(self.sprites.panel(w, band.height, 160), band)
        self.text.blit(surface, title, size + 6, (235, 245, 255), (20, band.centery), "midleft")
        x = w - 20
        for i in reversed(range(len(steps))):
            lit = i == current
            rect = self.text.blit(surface, f"{i + 1} {steps[i]}", size, (255, 230, 120) if lit else DIM_TEXT,
                                  (x, band.centery), "midright")
            if lit:
                pygame.draw.line(surface, (255, 230, 120), (rect.left, rect.bottom + 2),
                                 (rect.right, rect.bottom + 2), 2)
            x = rect.left - 30

    def draw_setup_text(self, surface: pygame.Surface, rect, message: str, lines: Sequence[str], keys: str,
                        warn: bool = False) -> None:
        """The maker's panel: the procedure's line (big; warm when something is wrong), the figures, the keys."""
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        h = surface.get_height()
        big, small = max(18, h // 28), max(15, h // 36)
        size = big
        while size > small and self.text.font(size).size(message)[0] > rect.width - 28:
            size -= 1  # a long line: smaller, so it stays one line
        colour = (255, 170, 110) if warn else (255, 240, 170)
        y = self.text.blit(surface, message, size, colour, (rect.left + 14, rect.top + 10)).bottom + 8
        for line in lines:
            if y + small > rect.bottom - small - 12:
                break
            y = self.text.blit(surface, line, small, TEXT, (rect.left + 14, y)).bottom + 3
        self.text.blit(surface, keys, small, DIM_TEXT, (rect.left + 14, rect.bottom - 8), "bottomleft")


def face_normal(face: str) -> np.ndarray:
    """The outward unit normal of a face ("+x", "-z", ...), sensor frame."""
    n = np.zeros(3)
    n["xyz".index(face[1])] = 1.0 if face[0] == "+" else -1.0
    return n


def face_corners(face: str) -> list[np.ndarray]:
    """A face's four corners (sensor frame, the board's size), in order around it."""
    axis = "xyz".index(face[1])
    u, v = [a for a in range(3) if a != axis]
    half = np.array(BOARD_HALF)
    corners = []
    for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        c = face_normal(face) * half
        c[u], c[v] = su * half[u], sv * half[v]
        corners.append(c)
    return corners


def rotation_to_up(up: np.ndarray) -> np.ndarray:
    """The rotation R (3 x 3) that turns the sensor-frame vector ``up`` onto the world's +z.

    Rodrigues' formula for the shortest turn; for ``up`` along -z (the board upside
    down), half a turn about x. A zero vector leaves the board as it is.
    """
    n = float(np.linalg.norm(up))
    if n == 0.0 or not np.isfinite(n):
        return np.eye(3)
    a = up / n
    z = np.array((0.0, 0.0, 1.0))
    axis = np.cross(a, z)
    s, c = float(np.linalg.norm(axis)), float(a @ z)
    if s < 1e-9:
        return np.eye(3) if c > 0 else np.diag((1.0, -1.0, -1.0))
    k = axis / s
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + s * kx + (1.0 - c) * (kx @ kx)


def view_rotation(turn: float, pitch: float) -> np.ndarray:
    """World (z up) to screen (x right, y up, z toward the viewer): a turn about the vertical,
    then the viewer raised by ``pitch`` above the horizon."""
    ct, st = math.cos(turn), math.sin(turn)
    yaw = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    cp, sp = math.cos(pitch), math.sin(pitch)
    # world x -> screen x; world z (up) -> screen y tipped toward the viewer; world -y -> out of the screen
    look = np.array([[1.0, 0.0, 0.0], [0.0, sp, cp], [0.0, -cp, sp]])
    return look @ yaw


def board_view(up: np.ndarray, turn: float) -> np.ndarray:
    """Sensor frame to screen frame for the board with ``up`` up, seen from :data:`VIEW_PITCH` above."""
    return view_rotation(turn - 0.6, VIEW_PITCH) @ rotation_to_up(up)


def visible_faces(view: np.ndarray) -> list[str]:
    """The faces that face the viewer (screen z > 0) under ``view``: a convex box needs no sorting."""
    return [f for f in BOARD_FACES if float((view @ face_normal(f))[2]) > 1e-6]


def _to_screen(p: np.ndarray, centre: np.ndarray, scale: float) -> tuple[int, int]:
    """A screen-frame point (x right, y up) to pixels (orthographic)."""
    return int(round(centre[0] + scale * p[0])), int(round(centre[1] - scale * p[1]))


def globe_image(radius: int, cells: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                colours: np.ndarray) -> np.ndarray:
    """An image (2r+1, 2r+1, 3) of a globe (:func:`globe_cells`): each pixel the colour of its nearest
    direction (``colours``, one row per direction), shaded, the cells' borders dark, black outside
    the disc (the colour key)."""
    inside, best, border, shade = cells
    rgb = colours[best] * shade[:, None]
    rgb[border] *= 0.45
    image = np.zeros((2 * radius + 1, 2 * radius + 1, 3), dtype=np.uint8)
    image[inside] = np.clip(rgb, 1, 255).astype(np.uint8)  # 1: never the colour key inside the disc
    return image


def globe_cells(radius: int, view: np.ndarray, directions: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A globe's geometry: the unit sphere of radius ``radius`` px under ``view``; which pixels lie
    on the disc, each one's nearest of ``directions`` (n, 3) (an index), whether it lies on a border
    between two cells, and its shading by :data:`LIGHT_DIR`."""
    y, x = np.mgrid[radius:-radius - 1:-1, -radius:radius + 1] / radius  # rows top to bottom: y up
    r2 = x * x + y * y
    inside = r2 < 1.0
    screen = np.stack([x[inside], y[inside], np.sqrt(1.0 - r2[inside])], axis=1)
    dots = (screen @ view) @ np.asarray(directions).T  # view^T turns screen points back to the sensor frame
    rows = np.arange(len(dots))
    best = np.argmax(dots, axis=1)
    nearest = dots[rows, best]
    dots[rows, best] = -np.inf
    border = nearest - np.max(dots, axis=1) < 0.018
    shade = 0.35 + 0.65 * np.clip(screen @ LIGHT_DIR, 0.0, 1.0)
    return inside, best, border, shade
