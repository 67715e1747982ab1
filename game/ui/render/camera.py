"""The third-person camera, and the frame's one projection.

Speed (the render budget is 3 ms a frame at 1280x720): every point of the
frame (grid, ring, zombie joints, shadows, balls, trails, particles, the
avatar) goes into one :class:`Batch` and through ONE camera transform and
projection per frame (:meth:`Camera.frame`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np


def clip_pixels(xy: np.ndarray) -> np.ndarray:
    """Pixel coordinates kept within +-30000 (pygame and SDL_gfx take 16-bit coordinates)."""
    return np.minimum(np.maximum(xy, -30000.0), 30000.0)


def clip_near(a: np.ndarray, b: np.ndarray, near: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clip camera-space segments a->b (N, 3) against the plane depth = ``near``.

    Returns the clipped end points and ``keep`` (N,): False where both ends lie
    behind the plane. An end behind the plane moves along the segment onto it.
    """
    za, zb = a[:, 2], b[:, 2]
    keep = (za > near) | (zb > near)
    denom = zb - za
    t = (near - za) / np.where(np.abs(denom) < 1e-12, 1e-12, denom)
    cut = a + (b - a) * t[:, None]
    a_out = np.where(((za < near) & keep)[:, None], cut, a)
    b_out = np.where(((zb < near) & keep)[:, None], cut, b)
    return a_out, b_out, keep


def depth_order(depths: np.ndarray) -> np.ndarray:
    """Indices that draw far things first (painter's algorithm); stable for equal depths."""
    return np.argsort(-np.asarray(depths, dtype=float), kind="stable")


class Batch:
    """Collects point sets for the frame's single projection; hands back slices."""

    def __init__(self) -> None:
        self.parts: list[np.ndarray] = []
        self.n = 0

    def add(self, points) -> slice:
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        sl = slice(self.n, self.n + len(points))
        self.parts.append(points)
        self.n += len(points)
        return sl

    def array(self) -> np.ndarray:
        return np.concatenate(self.parts) if self.parts else np.zeros((0, 3))


@dataclass
class Frame:
    """The frame's single projection: camera coordinates, pixels, depth, visibility, int pixels."""

    cam: np.ndarray
    xy: np.ndarray
    depth: np.ndarray
    visible: np.ndarray
    ixy: np.ndarray  # int32 pixels, clipped to +-30000 (safe for pygame)


@dataclass(frozen=True)
class CameraRig:
    """Where the third-person camera sits relative to the player (metres, seconds, degrees)."""

    back: float = 4.5  # behind the player
    up: float = 2.6  # above the ground
    ahead: float = 6.0  # it looks at a point this far ahead ...
    look_height: float = 1.3  # ... at chest height
    fov_y_deg: float = 60.0  # vertical field of view
    near: float = 0.2  # near plane depth
    follow_s: float = 0.12  # time constant of the position smoothing
    turn_s: float = 0.18  # time constant of the yaw smoothing


class Camera:
    """A pinhole camera without roll, following the player from behind and above.

    ``rot`` holds the camera's right, up and forward axes as rows (world
    frame), so camera coordinates are ``rot @ (p - eye)``; a point at depth
    ``z`` with camera offsets ``(x, y)`` lands at pixel
    ``(cx + f x / z, cy - f y / z)`` with ``f = (h / 2) / tan(fov_y / 2)``.
    """

    def __init__(self, rig: CameraRig | None = None, viewport: tuple[int, int] = (1280, 720)) -> None:
        self.rig = rig or CameraRig()
        self.near = self.rig.near
        self.width = self.height = 0
        self.f = self.cx = self.cy = 0.0
        self.set_viewport(*viewport)
        self.eye, self.rot = np.zeros(3), np.eye(3)
        self._place(0.0, 0.0, 0.0)
        self.state: tuple[float, float, float] | None = None  # smoothed (x, y, yaw); the first follow() snaps

    def set_viewport(self, width: int, height: int) -> None:
        """Take the surface's size (called each frame: the window is resizable)."""
        self.width, self.height = int(width), int(height)
        self.cx, self.cy = 0.5 * self.width, 0.5 * self.height
        self.f = 0.5 * self.height / math.tan(math.radians(self.rig.fov_y_deg) / 2)

    def look_at(self, eye: Sequence[float], target: Sequence[float]) -> None:
        """Place the camera at ``eye`` looking at ``target``, world z up (no roll)."""
        ex, ey, ez = (float(v) for v in eye)
        fx, fy, fz = float(target[0]) - ex, float(target[1]) - ey, float(target[2]) - ez
        n = math.sqrt(fx * fx + fy * fy + fz * fz)
        fx, fy, fz = fx / n, fy / n, fz / n
        h = math.hypot(fx, fy)
        rx, ry = (fy / h, -fx / h) if h > 1e-9 else (1.0, 0.0)  # forward x world up
        up = (ry * fz, -rx * fz, rx * fy - ry * fx)  # right x forward
        self.eye = np.array([ex, ey, ez])
        self.rot = np.array([[rx, ry, 0.0], up, [fx, fy, fz]])

    def snap(self, x: float, y: float, yaw: float) -> None:
        """Jump straight to the pose behind a player at (x, y) facing ``yaw``."""
        self.state = (float(x), float(y), float(yaw))
        self._place(*self.state)

    def follow(self, x: float, y: float, yaw: float, dt: float) -> None:
        """Move smoothly toward the pose behind the player (exponential smoothing, yaw wrapped)."""
        if self.state is None:
            self.snap(x, y, yaw)
            return
        sx, sy, syaw = self.state
        a = 1.0 - math.exp(-max(dt, 0.0) / self.rig.follow_s)
        b = 1.0 - math.exp(-max(dt, 0.0) / self.rig.turn_s)
        turn = (yaw - syaw + math.pi) % (2 * math.pi) - math.pi
        self.state = (sx + (x - sx) * a, sy + (y - sy) * a, syaw + turn * b)
        self._place(*self.state)

    def pose(self) -> tuple[float, ...]:
        """The viewport, focal length, eye and axes: equal for two frames that see the world alike."""
        return (self.width, self.height, self.f, *self.eye.tolist(), *self.rot.ravel().tolist())

    @property
    def yaw(self) -> float:
        return self.state[2] if self.state else 0.0

    def _place(self, x: float, y: float, yaw: float) -> None:
        fx, fy = -math.sin(yaw), math.cos(yaw)  # yaw 0 faces +y, positive turns left
        r = self.rig
        self.look_at((x - fx * r.back, y - fy * r.back, r.up), (x + fx * r.ahead, y + fy * r.ahead, r.look_height))

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points (N, 3) -> camera coordinates (N, 3): right, up, depth."""
        return (np.asarray(points, dtype=float).reshape(-1, 3) - self.eye) @ self.rot.T

    def project_camera(self, cam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Camera coordinates -> (pixels (N, 2), depth (N,), visible (N,): in front of the near plane)."""
        z = cam[:, 2]
        visible = z > self.near
        inv = self.f / np.where(visible, z, self.near)
        xy = np.empty((len(cam), 2))
        xy[:, 0] = self.cx + cam[:, 0] * inv
        xy[:, 1] = self.cy - cam[:, 1] * inv
        return xy, z, visible

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World points (N, 3) -> (screen xy (N, 2), depth (N,), visible mask (N,))."""
        return self.project_camera(self.to_camera(points))

    def project_segments(self, a: np.ndarray, b: np.ndarray, near: float | None = None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World segments a->b (N, 3) clipped against the near plane, then projected: (xy_a, xy_b, keep)."""
        ca, cb, keep = clip_near(self.to_camera(a), self.to_camera(b), self.near if near is None else near)
        return self.project_camera(ca)[0], self.project_camera(cb)[0], keep

    def horizon_y(self) -> float:
        """The screen row of the horizon (the camera never rolls, so it is one row)."""
        f = self.rot[2]
        flat = np.array([f[0], f[1], 0.0])
        n = np.linalg.norm(flat)
        if n < 1e-9:
            return -1e9 if f[2] < 0 else 1e9
        c = self.rot @ (flat / n)
        return self.cy - self.f * c[1] / c[2]

    def ground_depth(self, rows: np.ndarray) -> np.ndarray:
        """Depth of the ground plane seen through each screen row (inf at and above the horizon)."""
        dz = self.rot[2, 2] - (np.asarray(rows, dtype=float) - self.cy) / self.f * self.rot[1, 2]
        with np.errstate(divide="ignore"):
            return np.where(dz < -1e-9, -self.eye[2] / np.minimum(dz, -1e-9), np.inf)

    def frame(self, points: np.ndarray) -> Frame:
        """The frame's single projection of world points (N, 3)."""
        camp = self.to_camera(points)
        xy, depth, visible = self.project_camera(camp)
        return Frame(camp, xy, depth, visible, clip_pixels(xy).astype(np.int32))

    def screen_segments(self, ca: np.ndarray, cb: np.ndarray, near: float):
        """Clip camera-space segments, project them, drop those entirely off one side of the screen."""
        ca, cb, keep = clip_near(ca, cb, near)
        xy = clip_pixels(self.project_camera(np.concatenate([ca, cb]))[0]).reshape(2, len(ca), 2)
        lo, hi = np.minimum(xy[0], xy[1]), np.maximum(xy[0], xy[1])
        keep &= (hi[:, 0] >= 0) & (hi[:, 1] >= 0) & (lo[:, 0] <= self.width) & (lo[:, 1] <= self.height)
        return xy[0], xy[1], keep
