"""The actors: the zombies (posed all at once), the player's avatar, the balls in flight and at the hand.

Each is planned as a (depth, paint function, payload, probe points) record;
the renderer sorts them far to near with the town's boxes (painter's
algorithm) and paints them after the ground.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pygame

from .camera import Batch, Camera, Frame, depth_order
from .palette import (AVATAR_ARM, AVATAR_BODY, AVATAR_FREE_ARM, AVATAR_HAIR, AVATAR_HEAD, AVATAR_LEGS, FLYING_TINT,
                      HAZE, OUTLINE, ZOMBIE_ARMS, ZOMBIE_BODY, ZOMBIE_EYES, ZOMBIE_HEAD, ZOMBIE_LEGS, Colour)
from .sprites import SpriteCache
from .world import fog, setting

(Z_HIP, Z_NECK, Z_HEAD, Z_SHL, Z_SHR, Z_HANDL, Z_HANDR, Z_KNEEL, Z_KNEER, Z_FOOTL, Z_FOOTR,
 Z_EYEL, Z_EYER) = range(13)
Z_JOINTS = 13
Z_LEGS = [Z_FOOTL, Z_KNEEL, Z_HIP, Z_KNEER, Z_FOOTR]
Z_ARMS = [Z_HANDL, Z_SHL, Z_SHR, Z_HANDR]


def _zombie_pose_basis() -> tuple[np.ndarray, np.ndarray]:
    """The zombie's local poses as a template plus a linear basis (x right, y forward, z up, 1.8 m tall).

    A pose is ``template + coefficients @ basis`` with the coefficients
    [sin(phase), max(cos, 0), max(-cos, 0)] for a walker (stride, left and
    right foot lift with a body bob) and [1, sin(f), sin(1.3 f + 1)] for a
    flier (the flying template, then its flailing): one matrix product for all zombies.
    """
    walk = np.array([[0, 0, 0.95], [0, 0.12, 1.50], [0, 0.18, 1.66], [-0.2, 0.10, 1.45], [0.2, 0.10, 1.45],
                     [-0.17, 0.70, 1.38], [0.17, 0.70, 1.38], [-0.11, 0.06, 0.50], [0.11, 0.06, 0.50],
                     [-0.13, 0.0, 0.0], [0.13, 0.0, 0.0], [-0.05, 0.30, 1.70], [0.05, 0.30, 1.70]])
    fly = np.array([[0, 0, 0.95], [0, 0, 1.50], [0, 0.03, 1.68], [-0.2, 0, 1.45], [0.2, 0, 1.45],
                    [-0.55, 0, 1.75], [0.55, 0, 1.75], [-0.2, 0, 0.50], [0.2, 0, 0.50],
                    [-0.28, 0, 0.08], [0.28, 0, 0.08], [-0.05, 0.13, 1.70], [0.05, 0.13, 1.70]])
    basis = np.zeros((6, Z_JOINTS, 3))
    stride, lift_l, lift_r, to_fly, flail, kick = basis
    for j, (k_stride, k_flail, k_kick) in {Z_FOOTL: (0.28, 0, 0.35), Z_FOOTR: (-0.28, 0, -0.35),
                                           Z_KNEEL: (0.14, 0.25, 0), Z_KNEER: (-0.14, -0.25, 0)}.items():
        stride[j, 1], flail[j, 1], kick[j, 1] = k_stride, k_flail, k_kick
    stride[Z_HANDL, 2], stride[Z_HANDR, 2] = 0.07, -0.07
    lift_l[:, 2], lift_r[:, 2] = 0.03, 0.03  # the bob
    lift_l[Z_FOOTL, 2] += 0.10
    lift_r[Z_FOOTR, 2] += 0.10
    to_fly[:] = fly - walk
    flail[Z_HANDL, 2], flail[Z_HANDR, 2] = 0.25, -0.25
    kick[Z_HANDL, 1], kick[Z_HANDR, 1] = 0.2, -0.2
    return walk.reshape(-1), basis.reshape(6, -1)


_Z_TEMPLATE, _Z_BASIS = _zombie_pose_basis()


def zombie_joints(x, y, z, phase, heading, spin, flying, age, height: float = 1.8) -> np.ndarray:
    """World joint positions (N, 13, 3) of N zombies, all at once.

    Walking: the classic shamble, arms reaching forward, legs and arms swinging
    with ``phase``. Flying: flailing limbs, the whole body tumbling by ``spin``
    about its own right-left axis through the hips.
    """
    x, y, z, phase, heading, spin, age = (np.asarray(v, dtype=float) for v in (x, y, z, phase, heading, spin, age))
    fl = np.asarray(flying, dtype=float)
    wk = 1.0 - fl
    c = np.cos(phase)
    f = phase + 9.0 * age
    coef = np.column_stack([np.sin(phase) * wk, np.maximum(c, 0) * wk, np.maximum(-c, 0) * wk,
                            fl, np.sin(f) * fl, np.sin(1.3 * f + 1.0) * fl])
    local = (_Z_TEMPLATE + coef @ _Z_BASIS).reshape(-1, Z_JOINTS, 3)
    lx, ly, lz = local[:, :, 0], local[:, :, 1], local[:, :, 2] - 0.95
    a = (spin * fl)[:, None]  # tumble about the local x axis through the hips (0 for walkers)
    ca, sa = np.cos(a), np.sin(a)
    ly, lz = ly * ca - lz * sa, ly * sa + lz * ca
    k = height / 1.8
    sh, ch = np.sin(heading)[:, None] * k, np.cos(heading)[:, None] * k  # forward (ch, sh), right (sh, -ch)
    out = np.empty_like(local)
    out[:, :, 0] = x[:, None] + lx * sh + ly * ch
    out[:, :, 1] = y[:, None] - lx * ch + ly * sh
    out[:, :, 2] = z[:, None] + (lz + 0.95) * k
    return out


# ------------------------------------------------------------------ avatar parts


def avatar_parts(avatar, stride_phase: float = 0.0, stride_amp: float = 0.0
                 ) -> list[tuple[str, list[tuple[float, float, float]], float, Colour]]:
    """The avatar as capsule chains: (name, joints, width in metres, colour).

    The skeleton has no legs (the tracker does not see them): they are drawn
    from the hips to the ground, striding while the player walks.
    """
    wp = avatar.world_pos
    side = avatar.body.side
    other = "left" if side == "right" else "right"
    yaw = avatar.body_yaw
    rx, ry = math.cos(yaw), math.sin(yaw)  # body right
    fx, fy = -ry, rx  # body forward
    hips = wp["hips"]
    k = hips[2]  # the hips stand 1.0 m high at the reference height (game.body.avatar)
    legs = []
    for sign, swing in ((-1.0, 1.0), (1.0, -1.0)):
        step = 0.3 * stride_amp * swing * math.sin(stride_phase)
        lift = 0.08 * stride_amp * max(0.0, swing * math.cos(stride_phase))
        hip = (hips[0] + sign * 0.1 * rx, hips[1] + sign * 0.1 * ry, hips[2] - 0.04 * k)
        foot = (hips[0] + sign * 0.12 * rx + step * fx, hips[1] + sign * 0.12 * ry + step * fy, lift)
        knee = (0.5 * (hip[0] + foot[0]) + 0.06 * fx, 0.5 * (hip[1] + foot[1]) + 0.06 * fy, 0.5 * hip[2] + lift)
        legs.append([hip, knee, foot])

    def arm(s: str) -> list:
        return [wp[f"{s}_upper_arm"], wp[f"{s}_forearm"], wp[f"{s}_hand"], avatar.end_of(f"{s}_hand")]

    head = wp["head"]
    centre = (head[0], head[1], head[2] + 0.09 * k)
    return [
        ("leg_l", legs[0], 0.14, AVATAR_LEGS),
        ("leg_r", legs[1], 0.14, AVATAR_LEGS),
        ("torso", [hips, wp["chest"], wp["neck"]], 0.27, AVATAR_BODY),
        ("shoulders", [wp["left_upper_arm"], wp["right_upper_arm"]], 0.14, AVATAR_BODY),
        ("arm_free", arm(other), 0.095, AVATAR_FREE_ARM),
        ("arm_tracked", arm(side), 0.105, AVATAR_ARM),
        # the head: its centre, and a point on the face (to tell the face from the back of the head)
        ("head", [centre, (centre[0] + 0.12 * fx, centre[1] + 0.12 * fy, centre[2])], 0.23, AVATAR_HEAD),
    ]


def _zombie_colour_table() -> list:
    """Zombie part colours (legs, body, arms, head, outline) at 16 fog levels: walking, then flying."""
    base = np.array([ZOMBIE_LEGS, ZOMBIE_BODY, ZOMBIE_ARMS, ZOMBIE_HEAD, OUTLINE], dtype=float)
    table = []
    for tint in (0.0, 0.55):  # flying zombies glow a little
        cols = base * (1 - tint) + np.asarray(FLYING_TINT, float) * tint
        for level in range(16):
            fog = 0.85 * level / 15
            table.append((cols * (1 - fog) + np.asarray(HAZE, float) * fog).astype(int).tolist())
    return table


_ZOMBIE_COLOURS = _zombie_colour_table()


def paint_blits(surface: pygame.Surface, blits: list) -> list[pygame.Rect]:
    """Blit a list of (sprite, position, area, flags); returns the rectangles painted."""
    return surface.blits(blits) or []


def paint_calls(surface: pygame.Surface, calls: list) -> list[pygame.Rect]:
    """Paint a list of (function, arguments) with the surface as first argument; returns the rectangle round
    what the calls report painting (pygame.draw's and blit's; pygame.gfxdraw reports none), or none."""
    rects = []
    for fn, args in calls:
        rect = fn(surface, *args)
        if rect is not None:
            rects.append(rect)
    return [rects[0].unionall(rects[1:])] if rects else []


class RepeatedCalls:
    """Paint calls that come again frame after frame (the avatar standing still), painted from a picture.

    The calls are cut into runs at each blit (a glow adds to what lies
    beneath it, so it is always painted as it comes); a run of draw calls
    equal to the last frame's is painted once onto a scratch surface on a
    colour key and kept as a picture of the rectangle round it, and while
    the run stays the same one blit of the picture paints it. The draw calls
    paint opaque colours (none the key), each pixel the last call's, so the
    picture blitted gives the same pixels as the calls, in the same
    rectangle.
    """

    KEY = (255, 0, 255)

    def __init__(self) -> None:
        self._last: dict[int, list] = {}  # each run's calls at the last frame
        self._kept: dict[int, tuple[list, pygame.Surface, pygame.Rect]] = {}  # run: its calls, picture, place
        self._scratch: pygame.Surface | None = None

    def paint(self, surface: pygame.Surface, calls: list) -> list[pygame.Rect]:
        """Paint the calls (see the class's docstring); returns the rectangles painted, as :func:`paint_calls`."""
        rects: list[pygame.Rect] = []
        run: list = []
        k = 0
        for call in calls + [(pygame.Surface.blit, None)]:  # the end closes the last run
            if call[0] is not pygame.Surface.blit:
                run.append(call)
                continue
            if run:
                rects += self._paint_run(surface, k, run)
                k, run = k + 1, []
            if call[1] is not None:
                rects += paint_calls(surface, [call])
        return [rects[0].unionall(rects[1:])] if rects else []

    def _paint_run(self, surface: pygame.Surface, k: int, run: list) -> list[pygame.Rect]:
        kept = self._kept.get(k)
        if kept is None or kept[0] != run:
            if self._last.get(k) != run:  # new: paint it, remember it
                self._last[k] = run
                self._kept.pop(k, None)
                return paint_calls(surface, run)
            kept = self._kept[k] = (run, *self._picture(surface, run))  # the same twice: keep a picture
        _, picture, where = kept
        return [surface.blit(picture, where)] if where.width and where.height else []

    def _picture(self, surface: pygame.Surface, run: list) -> tuple[pygame.Surface, pygame.Rect]:
        """The run painted on the colour key, cut to the rectangle round it, and where it goes."""
        scratch = self._scratch
        if scratch is None or scratch.get_size() != surface.get_size():
            scratch = self._scratch = pygame.Surface(surface.get_size(), 0, surface)
        scratch.fill(self.KEY)
        rects = paint_calls(scratch, run)
        where = rects[0].clip(scratch.get_rect()) if rects else pygame.Rect(0, 0, 0, 0)
        picture = scratch.subsurface(where).copy() if where.width and where.height else pygame.Surface((0, 0))
        picture.set_colorkey(self.KEY)
        return picture, where


def _paint_zombie(surface: pygame.Surface, record: tuple) -> list[pygame.Rect]:
    """One zombie from its record (see :meth:`Actors._zombie_records`); returns the rectangle painted."""
    legs, arms, (hip, neck, head, eye_l, eye_r), limb, torso, head_r, colours, eyes = record
    legs_c, body_c, arms_c, head_c, out_c = colours
    lines, line, circle = pygame.draw.lines, pygame.draw.line, pygame.draw.circle
    rects = []
    if limb >= 7:  # near: a dark outline under each part, round joints
        rects += [lines(surface, out_c, False, legs, limb + 3), line(surface, out_c, hip, neck, torso + 3),
                  lines(surface, out_c, False, arms, limb + 3), circle(surface, out_c, head, head_r + 2)]
    rects += [lines(surface, legs_c, False, legs, limb), line(surface, body_c, hip, neck, torso),
              lines(surface, arms_c, False, arms, limb)]
    if limb >= 9:
        r = limb // 2
        rects += [circle(surface, legs_c, legs[1], r), circle(surface, legs_c, legs[3], r),
                  circle(surface, arms_c, arms[0], r), circle(surface, arms_c, arms[3], r)]
    rects.append(circle(surface, head_c, head, head_r))
    if eyes and head_r >= 5:
        r = max(1, head_r // 4)
        rects += [circle(surface, ZOMBIE_EYES, eye_l, r), circle(surface, ZOMBIE_EYES, eye_r, r)]
    return [rects[0].unionall(rects[1:])]


@dataclass
class ActorPoints:
    """Where each actor's points sit in the frame's projection batch."""

    za: np.ndarray  # zombies in view: x, y, z, phase, heading, spin, age, flying (one row each)
    s_zj: slice  # their joints, Z_JOINTS each
    s_zg: slice  # their ground points
    balls: list
    s_balls: slice
    s_bg: slice  # the balls' ground points
    s_trails: slice  # all trails, ball after ball
    trail_lengths: list
    held: object
    s_held: slice
    parts: list  # avatar_parts()
    s_parts: list
    s_av: slice  # the avatar's ground point


@dataclass
class ActorPlan:
    """The actors of a frame, planned: what to paint, and what the paint order needs (:meth:`Renderer._order
    <game.ui.render.renderer.Renderer._order>`), one row an actor, the zombies first."""

    items: list  # (paint function, payload)
    depth: np.ndarray  # (T,) the depth that sorts them far to near
    probes: np.ndarray  # (P,) the batch indices of the points that say what covers each (:mod:`.occlusion`)
    owner: np.ndarray  # (P,) the actor of each probe
    extents: np.ndarray  # (T, 5) the screen box round all an actor paints and its nearest depth; NaN if unknown


class Actors:
    """Plans the zombies, the balls and the avatar of a frame; the avatar's legs stride as it moves."""

    TOO_CLOSE = 2.0  # zombies nearer the camera than this (m) are not drawn: they would fill the view
    THICK_M = 0.4  # how far a zombie's body reaches in front of its joints (m), and a margin

    def __init__(self, camera: Camera, sprites: SpriteCache, rng: np.random.Generator) -> None:
        self.camera = camera
        self.sprites = sprites
        self.rng = rng  # the held ball's crackle
        self._stride = [0.0, 0.0, None]  # phase, amplitude, last position
        self._avatar = RepeatedCalls()  # standing still, the avatar is one blit

    def update_stride(self, avatar, dt: float) -> None:
        """The legs stride while the avatar moves (the skeleton has none: the tracker does not see them)."""
        if avatar is None:
            return
        phase, amp, last = self._stride
        pos = tuple(avatar.position)
        moved = math.dist(pos, last) if last is not None else 0.0
        if dt > 0:
            phase += moved / 0.55 * math.pi
            amp += (min(1.0, moved / dt / 2.0) - amp) * (1 - math.exp(-dt / 0.12))
        self._stride = [phase, amp, pos]

    def gather(self, batch: Batch, arena, avatar, settings) -> ActorPoints:
        """The zombies in view (joints, ground points), the balls and their trails, the held ball and the avatar."""
        cam = self.camera
        za = np.array([(z.x, z.y, z.z, z.phase, z.heading, z.spin, z.age, z.state == "flying")
                       for z in arena.zombies if z.state != "gone"], dtype=float).reshape(-1, 8)
        if len(za):  # skip zombies behind the camera or far out to the side before posing them
            c = cam.to_camera(np.column_stack([za[:, 0], za[:, 1], za[:, 2] + 0.9]))
            za = za[(c[:, 2] > self.TOO_CLOSE - 1.0) & (np.abs(c[:, 0]) < c[:, 2] * (cam.cx / cam.f) + 1.5)]
        s_zj = batch.add(zombie_joints(za[:, 0], za[:, 1], za[:, 2], za[:, 3], za[:, 4], za[:, 5], za[:, 7] > 0,
                                       za[:, 6], setting(settings, ("zombie_height_m", "zombie_height"), 1.8)))
        s_zg = batch.add(np.column_stack([za[:, 0], za[:, 1], np.zeros(len(za))]))
        balls = list(getattr(arena, "balls", ()))
        s_balls = batch.add([b.position for b in balls])
        s_bg = batch.add([(b.position[0], b.position[1], 0.0) for b in balls])
        trail_points = [p for b in balls for p in b.trail]
        s_trails = batch.add(trail_points)
        held = getattr(arena, "held", None)
        parts = avatar_parts(avatar, self._stride[0], self._stride[1]) if avatar is not None else []
        return ActorPoints(
            za, s_zj, s_zg, balls, s_balls, s_bg, s_trails, [len(b.trail) for b in balls],
            held, batch.add([held.position] if held is not None else []), parts,
            [batch.add(pts) for _, pts, _, _ in parts],
            batch.add([(avatar.position[0], avatar.position[1], 0.0)] if avatar is not None else []))

    @staticmethod
    def shadow_spots(g: ActorPoints) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The shadows' ground points (batch indices), widths and heights above the ground (m): zombies
        (smaller and fainter when flying), balls, the avatar."""
        n_av = g.s_av.stop - g.s_av.start
        return (np.r_[g.s_zg, g.s_bg, g.s_av],
                np.concatenate([np.full(len(g.za), 0.75), [0.5 + 0.3 * b.charge for b in g.balls], np.full(n_av, 0.9)]),
                np.concatenate([g.za[:, 2], [b.position[2] for b in g.balls], np.zeros(n_av)]))

    @staticmethod
    def body_points(g: ActorPoints) -> np.ndarray:
        """The batch indices of the player's body, arm and held ball: what must never be hidden."""
        idx = [np.arange(sl.start, sl.stop) for sl in g.s_parts] + [np.arange(g.s_held.start, g.s_held.stop)]
        return np.concatenate(idx) if idx else np.zeros(0, dtype=int)

    def plan(self, frame: Frame, g: ActorPoints, settings) -> ActorPlan:
        """Zombies, balls, the held ball and the avatar in no order, as arrays (:class:`ActorPlan`): the
        zombies' all at once, then a row for each of the others."""
        items, depth, probes, owner = [], [np.zeros(0)], [np.zeros(0, dtype=int)], [np.zeros(0, dtype=int)]
        extents = np.zeros((0, 5))
        if len(g.za):
            zdepth, records, ok, extents = self._zombie_records(frame, g.s_zj, len(g.za), g.za[:, 7] > 0)
            first = g.s_zj.start + ok * Z_JOINTS
            items += [(_paint_zombie, rec) for rec in records]
            depth.append(zdepth)
            probes.append(np.stack([first + Z_HEAD, first + Z_HIP, first + Z_FOOTL, first + Z_FOOTR], 1).ravel())
            owner.append(np.repeat(np.arange(len(ok)), 4))
        others = []  # (depth, paint, payload, probes)
        if g.balls:
            r0, r1 = setting(settings, ("ball_radius_m",), 0.22), setting(settings, ("ball_radius_per_charge_m",), 0.1)
            radii = [r0 + r1 * float(b.charge) for b in g.balls]
            fades = [float(b.fade) if b.state == "fading" else 1.0 for b in g.balls]
            trails = self._plan_trails(frame, g.s_trails, g.trail_lengths, radii, fades)
            for i, blits in enumerate(trails):
                j = g.s_balls.start + i
                if frame.visible[j]:
                    others.append((float(frame.depth[j]), paint_blits,
                                   blits + self._plan_ball(frame, j, radii[i], fades[i]), [j]))
        held, j = g.held, g.s_held.start
        if held is not None and held.visible and (held.state in ("loading", "spinning") or held.charge > 0) \
                and frame.visible[j]:
            others.append((float(frame.depth[j]), paint_calls, self._plan_held(frame, held, j), [j]))
        if g.parts and frame.visible[g.s_parts[2].start + 1]:  # the chest
            chest = g.s_parts[2].start + 1
            calls = self._plan_avatar(frame, g.parts, g.s_parts)
            others.append((float(frame.depth[chest]), self._avatar.paint, calls,
                           [chest, g.s_parts[-1].start]))  # the chest and the head
        if others:
            items += [(paint, payload) for _, paint, payload, _ in others]
            depth.append(np.array([t[0] for t in others]))
            probes.append(np.array([i for t in others for i in t[3]], dtype=int))
            owner.append(len(extents) + np.repeat(np.arange(len(others)), [len(t[3]) for t in others]))
        return ActorPlan(items, np.concatenate(depth), np.concatenate(probes), np.concatenate(owner),
                         np.vstack([extents, np.full((len(others), 5), np.nan)]))

    def _zombie_records(self, frame: Frame, sl: slice, n: int, flying: np.ndarray
                        ) -> tuple[np.ndarray, list, np.ndarray, np.ndarray]:
        """The zombies worth drawing (in front, not too close, on screen): their depths, paint records,
        indices (among the ``n``) and extents (x0, y0, x1, y1 pixels round all a zombie paints, and the
        depth of its nearest joint less its thickness).

        A record is (leg polyline, arm polyline, [hip, neck, head, eyes] pixels,
        limb width, torso width, head radius, colours, eyes shown).
        """
        cam = self.camera
        d = frame.depth[sl].reshape(n, Z_JOINTS)
        pts = frame.ixy[sl].reshape(n, Z_JOINTS, 2)
        lo, hi = pts.min(axis=1), pts.max(axis=1)  # whole pixels: the same tests against the whole margins
        ok = np.flatnonzero((d > cam.near + 0.3).all(axis=1) & (d[:, Z_HIP] > self.TOO_CLOSE)
                            & (hi[:, 0] > -20) & (lo[:, 0] < cam.width + 20)
                            & (hi[:, 1] > -20) & (lo[:, 1] < cam.height + 20))
        if not len(ok):
            return np.zeros(0), [], ok, np.zeros((0, 5))
        d, flying, pts, lo, hi = d[ok], flying[ok], pts[ok], lo[ok], hi[ok]
        hip = d[:, Z_HIP]
        ppm = cam.f / hip
        fog_level = (fog(hip) * (15.99 / 0.85)).astype(int) + 16 * flying
        limb, torso, head = (np.maximum(least, ppm * k).astype(int) for least, k in ((1, 0.11), (1, 0.22), (2, 0.13)))
        records = list(zip(pts[:, Z_LEGS].tolist(), pts[:, Z_ARMS].tolist(),
                           pts[:, [Z_HIP, Z_NECK, Z_HEAD, Z_EYEL, Z_EYER]].tolist(), limb.tolist(), torso.tolist(),
                           head.tolist(), [_ZOMBIE_COLOURS[i] for i in fog_level.tolist()],
                           (d[:, Z_EYEL] < d[:, Z_HEAD]).tolist()))  # eyes nearer than the head: facing us
        pad = (np.maximum(torso, head) + 5)[:, None]  # half the widest stroke (an outline), and a margin
        extents = np.column_stack([lo - pad, hi + pad, d.min(axis=1) - self.THICK_M])
        return hip, records, ok, extents

    def _plan_trails(self, frame: Frame, sl: slice, lengths: list, radii: list, fades: list) -> list:
        """Every ball's trail as glow blits, all at once: every other point, tapering, oldest faintest."""
        cam = self.camera
        n = sl.stop - sl.start
        if not n:
            return [[] for _ in lengths]
        owner = np.repeat(np.arange(len(lengths)), lengths)
        starts = np.cumsum(lengths) - np.asarray(lengths)
        age = np.arange(n) - starts[owner]  # 0 = oldest
        k = (age + 1) / np.asarray(lengths, dtype=float)[owner]  # 1 = newest
        pick = ((np.asarray(lengths)[owner] - 1 - age) % 2 == 0) & frame.visible[sl]
        depth = frame.depth[sl][pick]
        k, owner = k[pick], owner[pick]
        rad = cam.f * np.asarray(radii)[owner] * (0.3 + 0.8 * k) / depth
        level = np.minimum(3, (k * 3.2 * np.asarray(fades)[owner]).astype(int))
        blits = self.sprites.glow_blits(frame.xy[sl][pick], rad, np.zeros(len(k), np.int64), level)
        ends = np.searchsorted(owner, np.arange(len(lengths) + 1)).tolist()
        return [blits[a:b] for a, b in zip(ends[:-1], ends[1:])]

    def _plan_ball(self, frame: Frame, j: int, radius_m: float, fade: float) -> list:
        """A flying ball's halo and hot core (if on screen)."""
        cam = self.camera
        x, y = frame.xy[j]
        rpx = cam.f * radius_m / frame.depth[j]
        if not (-4 * rpx < x < cam.width + 4 * rpx and -4 * rpx < y < cam.height + 4 * rpx):
            return []
        level = max(0, min(3, int(fade * 3.99)))
        glow = self.sprites.glow_blit
        return [glow(x, y, 2.2 * rpx, "energy", level), glow(x, y, 1.1 * rpx, "white", level)]

    def _plan_held(self, frame: Frame, held, j: int) -> list:
        """The ball at the hand: bigger and brighter with charge; crackling bolts while it loads or spins."""
        cam = self.camera
        x, y = frame.xy[j]
        charge = min(max(float(held.charge), 0.0), 1.0)
        rpx = cam.f * (0.06 + 0.16 * charge) / frame.depth[j]
        level = min(3, 1 + int(charge * 3))
        blit, glow = pygame.Surface.blit, self.sprites.glow_blit
        calls = [(blit, glow(x, y, 2.4 * rpx, "energy", level)), (blit, glow(x, y, rpx, "white", level))]
        if held.state in ("loading", "spinning") and rpx >= 2:
            n_bolts = 2 + int(4 * charge)  # jagged bolts turning with the ball's spin, more as the charge grows
            angle = (held.spin + np.arange(n_bolts) * (2 * math.pi / n_bolts))[:, None] \
                + self.rng.normal(0, 0.35, (n_bolts, 3))
            reach = rpx * (0.8 + np.cumsum(self.rng.uniform(0.4, 0.9, (n_bolts, 3)), axis=1))
            bolts = np.empty((n_bolts, 4, 2))
            bolts[:, 0] = x, y
            bolts[:, 1:, 0] = x + reach * np.cos(angle)
            bolts[:, 1:, 1] = y + reach * np.sin(angle)
            colour = (170, 230, 255) if held.state == "loading" else (255, 240, 190)
            calls += [(pygame.draw.lines, (colour, False, pts)) for pts in bolts.astype(int).tolist()]
        return calls

    def _plan_avatar(self, frame: Frame, parts, slices) -> list:
        """Capsules, parts far to near: a dark outline pass, then the colour pass, joints as circles."""
        cam = self.camera
        line, circle = pygame.draw.line, pygame.draw.circle
        base, stop = slices[0].start, slices[-1].stop
        all_depth = frame.depth[base:stop].tolist()  # the parts' points, one after another: as lists at once
        all_pts, all_seen = frame.ixy[base:stop].tolist(), frame.visible[base:stop].tolist()
        depth = [sum(all_depth[s.start - base:s.stop - base]) / (s.stop - s.start) for s in slices]
        calls: list = []
        for k in depth_order(np.array(depth)).tolist():
            name, _, width_m, colour = parts[k]
            lo, hi = slices[k].start - base, slices[k].stop - base
            if not all(all_seen[lo:hi]):
                continue
            pts = all_pts[lo:hi]
            wpx = max(2, int(cam.f * width_m / depth[k]))
            if name == "head":  # seen from behind (the usual view): hair
                back = all_depth[lo + 1] > all_depth[lo]
                calls += [(circle, (OUTLINE, pts[0], wpx // 2 + 2)),
                          (circle, (AVATAR_HAIR if back else colour, pts[0], wpx // 2))]
                continue
            for col, ww in ((OUTLINE, wpx + 4), (colour, wpx)):
                calls += [(line, (col, a, b, ww)) for a, b in zip(pts[:-1], pts[1:])]
                calls += [(circle, (col, p, ww // 2)) for p in pts]
            if name == "arm_tracked":  # the tracked arm glows a little at the hand
                glow = self.sprites.glow_blit(pts[-1][0], pts[-1][1], wpx * 1.6, "spark", 0)
                calls.append((pygame.Surface.blit, glow))
        return calls
