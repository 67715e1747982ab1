"""Property tests of tracker.quat against scipy's Rotation as an independent oracle.

scipy stores quaternions scalar last (x, y, z, w); ``to_scipy`` / ``from_scipy``
convert at the boundary. Rotations are compared as matrices (sign-free).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from tracker import quat

ATOL = 1e-9
SQRT_HALF = np.sqrt(0.5)
TAIT_BRYAN = ["".join(p) for p in itertools.permutations("xyz")]
ORDERS = TAIT_BRYAN + [o.upper() for o in TAIT_BRYAN]

deterministic = settings(derandomize=True, max_examples=200, deadline=None)

finite = st.floats(-1.0, 1.0, allow_nan=False)
quats = (
    st.tuples(finite, finite, finite, finite)
    .map(np.array)
    .filter(lambda q: np.linalg.norm(q) > 0.1)
    .map(lambda q: q / np.linalg.norm(q))
)
vectors = st.tuples(*[st.floats(-10.0, 10.0, allow_nan=False)] * 3).map(np.array)
directions = vectors.filter(lambda v: np.linalg.norm(v) > 1e-3)
fractions = st.floats(-0.5, 1.5, allow_nan=False)
angles3 = st.tuples(*[st.floats(-np.pi, np.pi, allow_nan=False)] * 3).map(np.array)
seeds = st.integers(0, 2**32 - 1)


def to_scipy(q) -> Rotation:
    """scipy Rotation of scalar-first q (..., 4)."""
    return Rotation.from_quat(np.roll(np.reshape(q, (-1, 4)), -1, axis=-1))


def from_scipy(r: Rotation) -> np.ndarray:
    """Scalar-first quaternion(s) of a scipy Rotation."""
    return np.roll(r.as_quat(), 1, axis=-1)


def assert_same_rotation(p, q, atol=ATOL) -> None:
    np.testing.assert_allclose(to_scipy(p).as_matrix(), to_scipy(q).as_matrix(), atol=atol)


def assert_unit(q) -> None:
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=ATOL)


def random_quats(seed: int, shape: tuple[int, ...]) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=shape + (4,))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


# --- hand-worked physical cases -------------------------------------------------


def test_quarter_turn_about_z_maps_x_to_y():
    q = quat.from_axis_angle([0, 0, 1], np.pi / 2)
    np.testing.assert_allclose(q, [SQRT_HALF, 0, 0, SQRT_HALF], atol=ATOL)
    np.testing.assert_allclose(quat.rotate(q, [1, 0, 0]), [0, 1, 0], atol=ATOL)
    np.testing.assert_allclose(quat.rotate(q, [0, 1, 0]), [-1, 0, 0], atol=ATOL)
    np.testing.assert_allclose(quat.to_matrix(q), [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=ATOL)
    np.testing.assert_allclose(quat.to_rotvec(q), [0, 0, np.pi / 2], atol=ATOL)


def test_yaw_pitch_roll_hand_case():
    # Intrinsic ZYX (yaw 90, pitch 90, roll 0) is Rz(90) Ry(90): Ry takes x to -z, which
    # Rz keeps; Ry keeps y, which Rz takes to -x.
    q = quat.from_euler([np.pi / 2, np.pi / 2, 0], "ZYX")
    np.testing.assert_allclose(quat.rotate(q, [1, 0, 0]), [0, 0, -1], atol=ATOL)
    np.testing.assert_allclose(quat.rotate(q, [0, 1, 0]), [-1, 0, 0], atol=ATOL)
    np.testing.assert_allclose(quat.to_euler(q, "ZYX"), [np.pi / 2, np.pi / 2, 0], atol=1e-7)


def test_identity():
    np.testing.assert_array_equal(quat.identity(), [1, 0, 0, 0])
    assert quat.identity((2, 3)).shape == (2, 3, 4)
    np.testing.assert_array_equal(quat.rotate(quat.identity(), [1, 2, 3]), [1, 2, 3])


def test_accepts_lists_and_returns_float64():
    q = quat.multiply([1, 0, 0, 0], (0, 1, 0, 0))
    assert isinstance(q, np.ndarray) and q.dtype == np.float64
    assert quat.rotate([1, 0, 0, 0], [1, 2, 3]).dtype == np.float64


# --- algebra ------------------------------------------------------------------------


@deterministic
@given(quats, quats)
def test_multiply_is_rotation_composition(p, q):
    assert_same_rotation(quat.multiply(p, q), from_scipy(to_scipy(p) * to_scipy(q)))


@deterministic
@given(quats, quats, quats)
def test_multiply_is_associative(p, q, r):
    np.testing.assert_allclose(
        quat.multiply(quat.multiply(p, q), r), quat.multiply(p, quat.multiply(q, r)), atol=ATOL
    )


@deterministic
@given(quats)
def test_conjugate_is_inverse(q):
    np.testing.assert_allclose(quat.multiply(q, quat.conjugate(q)), quat.identity(), atol=ATOL)
    assert_same_rotation(quat.conjugate(q), from_scipy(to_scipy(q).inv()))


@deterministic
@given(st.tuples(*[st.floats(-1e3, 1e3)] * 4).map(np.array).filter(lambda q: max(abs(q)) > 1e-100))
def test_normalize_gives_unit_norm_same_direction(q):
    n = quat.normalize(q)
    assert_unit(n)
    np.testing.assert_allclose(n * np.linalg.norm(q), q, atol=ATOL)


@pytest.mark.parametrize(
    "bad", [[0, 0, 0, 0], [np.nan, 0, 0, 1], [np.inf, 0, 0, 0], [[1, 0, 0, 0], [0, 0, 0, 0]]]
)
def test_normalize_rejects_zero_and_non_finite(bad):
    with pytest.raises(ValueError, match="cannot normalise a zero or non-finite quaternion"):
        quat.normalize(bad)


@deterministic
@given(quats)
def test_canonical(q):
    c = quat.canonical(q)
    assert c[0] >= 0
    np.testing.assert_array_equal(c, quat.canonical(-q))
    np.testing.assert_array_equal(np.abs(c), np.abs(q))


def test_canonical_breaks_ties_at_zero_w():
    np.testing.assert_array_equal(quat.canonical([0, 0, -1, 1]), [0, 0, 1, -1])
    np.testing.assert_array_equal(
        quat.canonical([[-1, 0, 0, 0], [0, 0, 0, -1]]), [[1, 0, 0, 0], [0, 0, 0, 1]]
    )


# --- rotating vectors ---------------------------------------------------------------


@deterministic
@given(quats, vectors)
def test_rotate_matches_scipy_apply(q, v):
    np.testing.assert_allclose(quat.rotate(q, v), to_scipy(q).apply(v)[0], atol=ATOL)


@deterministic
@given(quats, vectors)
def test_rotate_is_sandwich_product(q, v):
    sandwich = quat.multiply(quat.multiply(q, np.r_[0.0, v]), quat.conjugate(q))
    np.testing.assert_allclose(sandwich[0], 0.0, atol=ATOL)
    np.testing.assert_allclose(quat.rotate(q, v), sandwich[1:], atol=ATOL)


# --- axis-angle, rotation vector, exp / log -----------------------------------------


@deterministic
@given(directions, st.floats(-2 * np.pi, 2 * np.pi, allow_nan=False))
def test_from_axis_angle_matches_scipy(axis, angle):
    unit = axis / np.linalg.norm(axis)
    expected = Rotation.from_rotvec(unit * angle)
    assert_same_rotation(quat.from_axis_angle(axis, angle), from_scipy(expected))


@deterministic
@given(quats)
def test_to_axis_angle_round_trip(q):
    axis, angle = quat.to_axis_angle(q)
    np.testing.assert_allclose(np.linalg.norm(axis), 1.0, atol=ATOL)
    assert 0.0 <= angle <= np.pi
    np.testing.assert_allclose(angle, to_scipy(q).magnitude()[0], atol=ATOL)
    assert_same_rotation(quat.from_axis_angle(axis, angle), q)


def test_axis_angle_of_identity_and_zero_axis():
    axis, angle = quat.to_axis_angle(quat.identity())
    np.testing.assert_array_equal(axis, [1, 0, 0])
    assert angle == 0.0
    with pytest.raises(ValueError, match="axis"):
        quat.from_axis_angle([0, 0, 0], 1.0)


@deterministic
@given(vectors)
def test_from_rotvec_matches_scipy(rv):
    assert_same_rotation(quat.from_rotvec(rv), from_scipy(Rotation.from_rotvec(rv)))


@deterministic
@given(quats)
def test_to_rotvec_matches_scipy(q):
    rv = quat.to_rotvec(q)
    assume(np.linalg.norm(rv) < np.pi - 1e-6)  # at pi, rv and -rv are the same rotation
    np.testing.assert_allclose(rv, to_scipy(q).as_rotvec()[0], atol=ATOL)
    np.testing.assert_allclose(quat.from_rotvec(rv), quat.canonical(q), atol=ATOL)


@deterministic
@given(directions, st.floats(1e-150, 1e-4))  # normal (not subnormal) floats
def test_rotvec_stable_near_zero(direction, size):
    rv = direction / np.linalg.norm(direction) * size
    q = quat.from_rotvec(rv)
    assert_unit(q)
    np.testing.assert_allclose(quat.to_rotvec(q), rv, rtol=1e-12, atol=1e-12 * size)


def test_rotvec_of_identity_is_exact_zero():
    with np.errstate(all="raise"):
        np.testing.assert_array_equal(quat.to_rotvec(quat.identity()), [0, 0, 0])
        np.testing.assert_array_equal(quat.from_rotvec([0, 0, 0]), [1, 0, 0, 0])


@deterministic
@given(quats)
def test_exp_log_round_trip_keeps_sign(q):
    v = quat.log(q)
    assert np.linalg.norm(v) <= np.pi + ATOL
    np.testing.assert_allclose(quat.exp(v), q, atol=ATOL)
    np.testing.assert_allclose(quat.to_rotvec(q), 2 * quat.log(quat.canonical(q)), atol=ATOL)


@deterministic
@given(vectors)
def test_exp_is_rotvec_of_twice_the_vector(v):
    np.testing.assert_allclose(quat.exp(v), quat.from_rotvec(2 * v), atol=ATOL)
    assert_same_rotation(quat.exp(v), from_scipy(Rotation.from_rotvec(2 * v)))
    assume(np.linalg.norm(v) < np.pi - 1e-6)
    np.testing.assert_allclose(quat.log(quat.exp(v)), v, atol=1e-8)


# --- matrices ----------------------------------------------------------------------


@deterministic
@given(quats)
def test_to_matrix_matches_scipy(q):
    np.testing.assert_allclose(quat.to_matrix(q), to_scipy(q).as_matrix()[0], atol=ATOL)


@deterministic
@given(quats)
def test_from_matrix_matches_scipy(q):
    m = to_scipy(q).as_matrix()[0]
    got = quat.from_matrix(m)
    assert got[0] >= 0
    assert_unit(got)
    assert_same_rotation(got, from_scipy(Rotation.from_matrix(m)))
    assert_same_rotation(got, q)


@pytest.mark.parametrize(
    "m, q",
    [
        (np.diag([1.0, -1.0, -1.0]), [0, 1, 0, 0]),  # half-turns: trace -1, Shepperd's hard cases
        (np.diag([-1.0, 1.0, -1.0]), [0, 0, 1, 0]),
        (np.diag([-1.0, -1.0, 1.0]), [0, 0, 0, 1]),
        (np.eye(3), [1, 0, 0, 0]),
    ],
)
def test_from_matrix_half_turns(m, q):
    np.testing.assert_allclose(quat.from_matrix(m), q, atol=ATOL)


@deterministic
@given(directions, st.floats(np.pi - 1e-6, np.pi))
def test_from_matrix_near_half_turn(axis, angle):
    q = quat.from_axis_angle(axis, angle)
    assert_same_rotation(quat.from_matrix(quat.to_matrix(q)), q)


# --- Euler angles ------------------------------------------------------------------


@deterministic
@given(angles3, st.sampled_from(ORDERS))
def test_from_euler_matches_scipy(angles, order):
    expected = Rotation.from_euler(order, angles)
    assert_same_rotation(quat.from_euler(angles, order), from_scipy(expected))


@deterministic
@given(quats, st.sampled_from(ORDERS))
def test_to_euler_matches_scipy_away_from_gimbal_lock(q, order):
    angles = quat.to_euler(q, order)
    assume(abs(abs(angles[1]) - np.pi / 2) > 1e-3)
    expected = to_scipy(q).as_euler(order)[0]
    # +-pi are the same angle: compare on the circle
    np.testing.assert_allclose(np.sin(angles - expected), 0, atol=ATOL)
    np.testing.assert_allclose(np.cos(angles - expected), 1, atol=ATOL)
    assert_same_rotation(quat.from_euler(angles, order), q)


@deterministic
@given(
    st.floats(-np.pi, np.pi),
    st.sampled_from([-np.pi / 2, np.pi / 2]),
    st.floats(-np.pi, np.pi),
    st.sampled_from(ORDERS),
)
def test_to_euler_in_gimbal_lock(first, middle, last, order):
    q = quat.from_euler([first, middle, last], order)
    angles = quat.to_euler(q, order)
    third = 2 if order.isupper() else 0  # the intrinsic sequence's last angle is set to zero
    assert angles[third] == 0.0
    np.testing.assert_allclose(angles[1], middle, atol=1e-7)
    assert_same_rotation(quat.from_euler(angles, order), q, atol=1e-7)


@deterministic
@given(angles3)
def test_extrinsic_is_reversed_intrinsic(angles):
    np.testing.assert_allclose(
        quat.from_euler(angles, "xyz"), quat.from_euler(angles[::-1], "ZYX"), atol=ATOL
    )


@pytest.mark.parametrize("order", ["xyx", "XyZ", "abc", "xy", "xyzx", "ZZY"])
def test_euler_rejects_bad_orders(order):
    with pytest.raises(ValueError, match="Euler order"):
        quat.from_euler([0, 0, 0], order)
    with pytest.raises(ValueError, match="Euler order"):
        quat.to_euler(quat.identity(), order)


# Unity's Quaternion.Euler(x, y, z) rotates z degrees about z, then x about x, then y
# about y, all about fixed axes: q = qy * qx * qz. In scipy's naming that is the
# extrinsic sequence "zxy" with angles (z, x, y), or equally the intrinsic sequence
# "YXZ" with angles (y, x, z) (R = Ry Rx Rz either way). Note it is *not* intrinsic
# "ZXY" with (z, x, y): that would be Rz Rx Ry, the reverse composition.
@deterministic
@given(angles3)
def test_unity_euler_composition_order(angles_rad):
    x, y, z = np.degrees(angles_rad)
    q = quat.unity_euler(x, y, z)
    assert_same_rotation(q, from_scipy(Rotation.from_euler("zxy", [z, x, y], degrees=True)))
    assert_same_rotation(q, from_scipy(Rotation.from_euler("YXZ", [y, x, z], degrees=True)))
    qx, qy, qz = (quat.from_axis_angle(axis, a) for axis, a in zip(np.eye(3), angles_rad))
    by_hand = quat.multiply(quat.multiply(qy, qx), qz)
    np.testing.assert_allclose(q, by_hand, atol=ATOL)


def test_unity_euler_hand_cases():
    # Unity: Quaternion.Euler(90, 0, 0) == (x, y, z, w) = (0.7071, 0, 0, 0.7071).
    np.testing.assert_allclose(quat.unity_euler(90, 0, 0), [SQRT_HALF, SQRT_HALF, 0, 0], atol=ATOL)
    # Euler(90, 90, 0) = qy(90) qx(90) = (c, 0, c, 0)(c, c, 0, 0) with c = sqrt(1/2):
    # w = c^2 = 1/2, vector = c(c,0,0) + c(0,c,0) + (0,c,0) x (c,0,0) = (1/2, 1/2, -1/2);
    # Unity gives (x, y, z, w) = (0.5, 0.5, -0.5, 0.5).
    q = quat.unity_euler(90, 90, 0)
    np.testing.assert_allclose(q, [0.5, 0.5, 0.5, -0.5], atol=ATOL)
    # x first turns about x (x stays), then y turns x to -z.
    np.testing.assert_allclose(quat.rotate(q, [1, 0, 0]), [0, 0, -1], atol=ATOL)
    # The paper's forearm: Euler(flex, -flex, 0), broadcast over an array of flex angles.
    flex = np.array([0.0, 30.0, 90.0])
    assert quat.unity_euler(flex, -flex, 0).shape == (3, 4)


# --- interpolation, two-vector rotations, angles --------------------------------------


@deterministic
@given(quats, quats, st.floats(0.0, 1.0))
def test_slerp_matches_scipy(q0, q1, t):
    assume(quat.angle_between(q0, q1) < np.pi - 1e-3)  # the shortest arc is unique
    expected = Slerp([0.0, 1.0], to_scipy(np.stack([q0, q1])))([t])
    got = quat.slerp(q0, q1, t)
    assert_unit(got)
    assert_same_rotation(got, from_scipy(expected))


@deterministic
@given(quats, quats, fractions)
def test_slerp_takes_shortest_path_and_constant_speed(q0, q1, t):
    angle = quat.angle_between(q0, q1)
    assume(angle < np.pi - 1e-3 and abs(t) * angle < np.pi)
    got = quat.slerp(q0, q1, t)
    np.testing.assert_allclose(got, quat.slerp(q0, -q1, t), atol=ATOL)
    np.testing.assert_allclose(quat.angle_between(q0, got), abs(t) * angle, atol=1e-8)


@deterministic
@given(quats, quats)
def test_slerp_endpoints(q0, q1):
    np.testing.assert_allclose(quat.slerp(q0, q1, 0.0), q0, atol=ATOL)
    assert_same_rotation(quat.slerp(q0, q1, 1.0), q1)


@deterministic
@given(quats, directions, st.floats(1e-15, 1e-6), fractions)
def test_slerp_nearly_equal(q0, axis, angle, t):
    q1 = quat.multiply(q0, quat.from_axis_angle(axis, angle))
    got = quat.slerp(q0, q1, t)
    assert np.all(np.isfinite(got))
    assert_unit(got)
    expected = quat.multiply(q0, quat.from_axis_angle(axis, t * angle))
    np.testing.assert_allclose(got, expected, atol=1e-15)


def test_slerp_broadcasts_t():
    q0, q1 = quat.identity(), quat.from_axis_angle([0, 0, 1], np.pi / 2)
    t = np.linspace(0, 1, 7)
    got = quat.slerp(q0, q1, t)
    assert got.shape == (7, 4)
    np.testing.assert_allclose(quat.to_rotvec(got)[:, 2], t * np.pi / 2, atol=ATOL)
    batch = quat.slerp(random_quats(0, (3,)), random_quats(1, (3,)), np.zeros((5, 1)))
    assert batch.shape == (5, 3, 4)


@deterministic
@given(directions, directions)
def test_from_two_vectors(a, b):
    q = quat.from_two_vectors(a, b)
    ua, ub = a / np.linalg.norm(a), b / np.linalg.norm(b)
    assert_unit(q)
    np.testing.assert_allclose(quat.rotate(q, ua), ub, atol=ATOL)
    expected_angle = np.arctan2(np.linalg.norm(np.cross(ua, ub)), ua @ ub)
    np.testing.assert_allclose(quat.to_axis_angle(q)[1], expected_angle, atol=ATOL)


@deterministic
@given(directions, st.floats(-1e3, 1e3).filter(lambda s: abs(s) > 1e-3))
def test_from_two_vectors_parallel_and_opposite(a, scale):
    q = quat.from_two_vectors(a, scale * a)
    expected = 0.0 if scale > 0 else np.pi
    np.testing.assert_allclose(quat.to_axis_angle(q)[1], expected, atol=ATOL)
    np.testing.assert_allclose(quat.rotate(q, a), np.sign(scale) * a, atol=ATOL * np.linalg.norm(a))


@deterministic
@given(directions, vectors, st.floats(1e-14, 1e-4))
def test_from_two_vectors_nearly_opposite(a, push, eps):
    ua = a / np.linalg.norm(a)
    b = -ua + eps * np.cross(ua, push)
    assume(np.linalg.norm(b) > 0)
    q = quat.from_two_vectors(ua, b)
    np.testing.assert_allclose(quat.rotate(q, ua), b / np.linalg.norm(b), atol=1e-12)


def test_from_two_vectors_rejects_zero():
    with pytest.raises(ValueError, match="vector"):
        quat.from_two_vectors([0, 0, 0], [1, 0, 0])


@deterministic
@given(quats, quats)
def test_angle_between_matches_scipy(p, q):
    expected = (to_scipy(p).inv() * to_scipy(q)).magnitude()[0]
    np.testing.assert_allclose(quat.angle_between(p, q), expected, atol=1e-8)
    np.testing.assert_allclose(quat.angle_between(-p, q), expected, atol=1e-8)
    np.testing.assert_allclose(quat.angle_between(p, -q), expected, atol=1e-8)


# --- vectorised shapes --------------------------------------------------------------


@deterministic
@given(seeds)
def test_vectorised_over_leading_axes(seed):
    """Every function on a (5, 3) batch agrees with scipy on the flattened batch."""
    shape = (5, 3)
    p, q = random_quats(seed, shape), random_quats(seed + 1, shape)
    v = np.random.default_rng(seed).normal(size=shape + (3,))
    unit = v / np.linalg.norm(v, axis=-1, keepdims=True)
    flat_v, rp, rq = v.reshape(-1, 3), to_scipy(p), to_scipy(q)

    def check(got, expected):
        assert got.shape[: len(shape)] == shape
        if isinstance(expected, Rotation):  # quaternions: compare as rotations
            got, expected = to_scipy(got).as_matrix(), expected.as_matrix()
        np.testing.assert_allclose(got.reshape(np.shape(expected)), expected, atol=1e-8)

    check(quat.multiply(p, q), rp * rq)
    check(quat.conjugate(p), rp.inv())
    check(quat.normalize(3 * p), rp)
    check(quat.canonical(p), rp)
    check(quat.rotate(p, v), rp.apply(flat_v))
    check(quat.from_rotvec(v), Rotation.from_rotvec(flat_v))
    check(quat.to_rotvec(p), rp.as_rotvec())
    check(quat.exp(v), Rotation.from_rotvec(2 * flat_v))
    check(quat.exp(quat.log(p)), p)
    check(quat.from_axis_angle(v, 0.5), Rotation.from_rotvec(0.5 * unit.reshape(-1, 3)))
    axis, angle = quat.to_axis_angle(p)
    check(axis * angle[..., None], rp.as_rotvec())
    check(quat.to_matrix(p), rp.as_matrix())
    check(quat.from_matrix(rp.as_matrix().reshape(shape + (3, 3))), rp)
    check(quat.angle_between(p, q), (rp.inv() * rq).magnitude())
    check(quat.slerp(p, q, 0.25), rp * Rotation.from_rotvec(0.25 * (rp.inv() * rq).as_rotvec()))
    for order in ORDERS:
        check(quat.from_euler(v, order), Rotation.from_euler(order, flat_v))
        check(quat.from_euler(quat.to_euler(p, order), order), rp)
    x, y, z = np.moveaxis(v, -1, 0)
    check(quat.unity_euler(x, y, z), Rotation.from_euler("zxy", flat_v[:, [2, 0, 1]], degrees=True))
    check(quat.rotate(quat.from_two_vectors(v, v[..., ::-1]), unit), unit[..., ::-1])
    assert quat.rotate(p, [1, 0, 0]).shape == shape + (3,)
    assert quat.slerp(p, q, np.zeros((2, 1, 1))).shape == (2,) + shape + (4,)
