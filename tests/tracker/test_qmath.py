"""Every function of tracker.fusion.qmath against tracker.quat (vectorised numpy,
itself tested against scipy), on seeded random inputs, plus huge, tiny, zero and
non-finite inputs where a streaming filter must not fail."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracker import quat as Q
from tracker.fusion import qmath as qm

N = 200
ATOL = 1e-12
SCALES = [1e-300, 1e-200, 1e-9, 1.0, 1e9, 1e200, 1e300]


def rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def quats(n: int = N, seed: int = 0) -> np.ndarray:
    q = rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def vecs(n: int = N, seed: int = 1, scale: float = 3.0) -> np.ndarray:
    return rng(seed).normal(size=(n, 3)) * scale


def t(a: np.ndarray) -> tuple:
    return tuple(float(x) for x in a)


def close(actual, expected, atol: float = ATOL) -> None:
    np.testing.assert_allclose(np.asarray(actual, float), np.asarray(expected, float), rtol=0, atol=atol)


def is_unit(q) -> bool:
    return abs(math.hypot(*q) - 1.0) < 1e-12


# ------------------------------------------------------------ quaternion algebra


def test_mul_conj_add_match_quat():
    p, q = quats(seed=0), quats(seed=1)
    close([qm.mul(t(a), t(b)) for a, b in zip(p, q)], Q.multiply(p, q))
    close([qm.conj(t(a)) for a in p], Q.conjugate(p))
    close([qm.add(t(a), t(b)) for a, b in zip(p, q)], p + q)


def test_rotate_and_rotate_inverse_match_quat():
    q, v = quats(seed=2), vecs(seed=3)
    close([qm.rotate(t(a), t(b)) for a, b in zip(q, v)], Q.rotate(q, v))
    close([qm.rotate_inverse(t(a), t(b)) for a, b in zip(q, v)], Q.rotate(Q.conjugate(q), v))


def test_normalize_matches_quat():
    q = rng(4).normal(size=(N, 4)) * rng(5).uniform(0.01, 100.0, size=(N, 1))
    close([qm.normalize(t(a)) for a in q], Q.normalize(q))


@pytest.mark.parametrize("scale", SCALES + [1e-305, 1e-310, 5e-324, 1e308])
def test_normalize_neither_overflows_nor_underflows(scale):
    q = quats(20, seed=6)
    for a in q:
        out = qm.normalize(t(a * scale))  # at 1e308 the squared norm (and, with 4 terms, the norm) overflows
        assert is_unit(out)
        if scale > 1e-308:  # subnormal components keep only a few bits
            close(out, a, atol=1e-12)


@pytest.mark.parametrize("bad", [(0.0, 0.0, 0.0, 0.0), (math.nan, 0.0, 0.0, 1.0),
                                 (math.inf, 0.0, 0.0, 0.0), (1.0, -math.inf, math.nan, 0.0)])
def test_normalize_of_zero_or_non_finite_is_the_identity(bad):
    assert qm.normalize(bad) == qm.IDENTITY


# ------------------------------------------------------------ rotation vectors


def test_from_rotvec_matches_quat_including_tiny_angles():
    v = vecs(seed=7) * rng(8).choice([1e-14, 1e-8, 1.0, 10.0], size=(N, 1))
    close([qm.from_rotvec(*t(a)) for a in v], Q.from_rotvec(v))
    assert qm.from_rotvec(0.0, 0.0, 0.0) == qm.IDENTITY


@pytest.mark.parametrize("angle", [1e3, 1e10, 1e200, 1e300])
def test_from_rotvec_of_a_huge_finite_angle_is_that_rotation(angle):
    axis = np.array([0.36, -0.48, 0.8])  # unit
    out = qm.from_rotvec(*t(axis * angle))
    assert is_unit(out)
    half = 0.5 * math.hypot(*(axis * angle))
    close(out, [math.cos(half), *(math.sin(half) * axis)], atol=1e-12)


@pytest.mark.parametrize("rv", [(1.5e308, 1.5e308, 1.5e308), (math.inf, 0.0, 0.0), (0.0, math.nan, 0.0),
                                (math.inf, math.nan, 1.0), (-math.inf, -math.inf, -math.inf)])
def test_from_rotvec_beyond_the_float_range_is_the_identity(rv):
    assert qm.from_rotvec(*rv) == qm.IDENTITY


@pytest.mark.parametrize("scale", [1e-300, 1e-200])
def test_from_rotvec_of_a_tiny_angle_is_unit_and_near_the_identity(scale):
    out = qm.from_rotvec(*t(vecs(1, seed=9)[0] * scale))
    assert is_unit(out)
    close(out, qm.IDENTITY, atol=1e-15)


def test_integrate_is_q_times_exp_of_half_omega_dt():
    q, w = quats(seed=10), vecs(seed=11)
    dt = 0.005
    close([qm.integrate(t(a), t(b), dt) for a, b in zip(q, w)], Q.multiply(q, Q.from_rotvec(w * dt)))


def test_about_z_matches_quat():
    angles = rng(12).uniform(-4 * math.pi, 4 * math.pi, N)
    close([qm.about_z(a) for a in angles], Q.from_axis_angle([0.0, 0.0, 1.0], angles))


def test_power_scales_the_angle_about_the_same_axis():
    q = Q.canonical(quats(seed=13))  # w >= 0, as between() returns
    k = rng(14).uniform(-1.5, 2.5, N)
    expected = Q.from_rotvec(k[:, None] * Q.to_rotvec(q))
    close([qm.power(t(a), float(b)) for a, b in zip(q, k)], expected)


def test_power_one_and_power_of_a_tiny_rotation_return_q():
    q = t(Q.canonical(quats(1, seed=15))[0])
    assert qm.power(q, 1.0) == q  # exactly q, untouched
    tiny = qm.from_rotvec(1e-14, 0.0, 0.0)
    assert qm.power(tiny, 0.3) == tiny


def test_slerp_matches_quat_along_the_shorter_arc():
    p, q = quats(seed=16), quats(seed=17)
    q[::2] = -q[::2]  # either sign of q is the same rotation
    tt = rng(18).uniform(0.0, 1.0, N)
    close([qm.slerp(t(a), t(b), float(c)) for a, b, c in zip(p, q, tt)], Q.slerp(p, q, tt))


def test_slerp_of_nearly_equal_quaternions_is_the_linear_blend():
    p = quats(1, seed=19)[0]
    q = Q.multiply(p, Q.from_rotvec([1e-8, 0.0, 0.0]))
    close(qm.slerp(t(p), t(q), 0.25), Q.slerp(p, q, 0.25), atol=1e-15)
    assert qm.slerp(t(p), t(-q), 0.0) == pytest.approx(t(p), abs=1e-15)


# ------------------------------------------------------------ vectors


def test_norm3_dot_cross_unit_match_numpy():
    a, b = vecs(seed=20), vecs(seed=21)
    close([qm.norm3(t(x)) for x in a], np.linalg.norm(a, axis=1))
    close([qm.dot(t(x), t(y)) for x, y in zip(a, b)], np.sum(a * b, axis=1))
    close([qm.cross(t(x), t(y)) for x, y in zip(a, b)], np.cross(a, b))
    close([qm.unit(t(x)) for x in a], a / np.linalg.norm(a, axis=1, keepdims=True))


@pytest.mark.parametrize("scale", SCALES)
def test_unit_neither_overflows_nor_underflows(scale):
    for v in vecs(20, seed=22):
        close(qm.unit(t(v * scale)), v / np.linalg.norm(v))


# ------------------------------------------------------------ rotations between directions


def test_between_matches_quat_from_two_vectors():
    u, v = vecs(seed=23), vecs(seed=24, scale=30.0)
    close([qm.between(t(a), t(b)) for a, b in zip(u, v)], Q.from_two_vectors(u, v), atol=1e-11)


@pytest.mark.parametrize("scale", SCALES)
def test_between_is_scale_free(scale):
    u, v = vecs(20, seed=25), vecs(20, seed=26)
    for a, b in zip(u, v):  # u and v at different scales, the one tiny and the other huge
        expected = Q.from_two_vectors(a, b)
        close(qm.between(t(a * scale), t(b / scale if scale > 1e-300 else b)), expected, atol=1e-11)


def test_between_opposite_vectors_is_a_half_turn_about_a_perpendicular_axis():
    for u in list(vecs(20, seed=27)) + [np.array([0.0, 0.0, -3.0]), np.array([2.0, 0.0, 0.0])]:
        q = qm.between(t(u), t(-u))
        assert is_unit(q) and abs(q[0]) < 1e-12
        close(Q.rotate(q, u), -u, atol=1e-12)
        q = qm.between(t(u * (1.0 + 1e-13)), t(-u + 1e-14))  # nearly opposite: still a rotation onto -u
        close(Q.rotate(q, u / np.linalg.norm(u)), -u / np.linalg.norm(u), atol=1e-6)


def test_between_opposite_vectors_uses_the_given_half_turn_axis():
    q = qm.between((0.0, 0.0, -2.0), qm.UP, qm.EAST)
    assert q == (0.0, 1.0, 0.0, 0.0)


@pytest.mark.parametrize("u, v", [((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0))])
def test_between_a_zero_vector_is_the_identity(u, v):
    assert qm.between(u, v) == qm.IDENTITY


def test_tilt_to_up_is_the_rotation_vector_of_between_v_and_up():
    v = vecs(seed=28, scale=9.81)
    fraction = rng(29).uniform(0.0, 1.0, N)
    expected = fraction[:, None] * Q.to_rotvec(Q.from_two_vectors(v, [0.0, 0.0, 1.0]))
    close([qm.tilt_to_up(t(a), float(f)) for a, f in zip(v, fraction)], expected, atol=1e-11)
    for a in v:  # the full rotation takes v onto up, turning about a horizontal axis
        rv = qm.tilt_to_up(t(a))
        assert rv[2] == 0.0
        close(Q.rotate(qm.from_rotvec(*rv), a / np.linalg.norm(a)), [0.0, 0.0, 1.0])


@pytest.mark.parametrize("scale", SCALES)
def test_tilt_to_up_is_scale_free(scale):
    for a in vecs(20, seed=30):
        close(qm.tilt_to_up(t(a * scale), 0.5), 0.5 * Q.to_rotvec(Q.from_two_vectors(a, [0.0, 0.0, 1.0])),
              atol=1e-11)


def test_tilt_to_up_of_vertical_vectors():
    assert qm.tilt_to_up((0.0, 0.0, 9.81)) == (0.0, 0.0, 0.0)
    assert qm.tilt_to_up((1e-14, 0.0, 9.81)) == (0.0, 0.0, 0.0)
    assert qm.tilt_to_up((0.0, 0.0, 0.0)) == (0.0, 0.0, 0.0)
    assert qm.tilt_to_up((0.0, 0.0, -9.81), 0.25) == (0.25 * math.pi, 0.0, 0.0)  # a half-turn about east


def test_align_heading_turns_about_up_onto_the_reference():
    q, vec_s, ref_w = quats(seed=31), vecs(seed=32), vecs(seed=33)
    h = Q.rotate(q, vec_s)
    turn = np.arctan2(ref_w[:, 1], ref_w[:, 0]) - np.arctan2(h[:, 1], h[:, 0])
    turn = (turn + np.pi) % (2 * np.pi) - np.pi  # the shorter way, as qmath turns
    expected = Q.multiply(Q.from_axis_angle([0.0, 0.0, 1.0], turn), q)
    out = np.array([qm.align_heading(t(a), t(b), t(c)) for a, b, c in zip(q, vec_s, ref_w)])
    close(out, expected, atol=1e-11)
    h_new = Q.rotate(out, vec_s)
    close(np.arctan2(h_new[:, 0] * ref_w[:, 1] - h_new[:, 1] * ref_w[:, 0],
                     h_new[:, 0] * ref_w[:, 0] + h_new[:, 1] * ref_w[:, 1]), 0.0, atol=1e-11)
    close(h_new[:, 2], h[:, 2], atol=1e-11)  # a turn about up keeps the vertical part


@pytest.mark.parametrize("scale", [1e-200, 1.0, 1e200])
def test_align_heading_is_scale_free(scale):
    q, vec_s = t(quats(1, seed=34)[0]), t(vecs(1, seed=35)[0])
    expected = qm.align_heading(q, vec_s, qm.NORTH)
    close(qm.align_heading(q, t(np.array(vec_s) * scale), t(np.array(qm.NORTH) * scale)), expected)


def test_align_heading_leaves_q_alone_where_a_vector_is_vertical():
    q = t(quats(1, seed=36)[0])
    up_s = t(Q.rotate(Q.conjugate(q), [0.0, 0.0, 5.0]))  # q up_s q* is vertical
    assert qm.align_heading(q, up_s, qm.NORTH) == q  # exactly q, untouched
    assert qm.align_heading(q, (1.0, 2.0, 3.0), (0.0, 0.0, -1.0)) == q
