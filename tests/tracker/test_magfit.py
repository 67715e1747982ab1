"""Magnetometer calibration (tracker.magfit): hard and soft iron recovered from the simulated board.

The oracle is tracker.sim: its AK8963 reads (I + E) R^T (m + d(p)) + h with
the hard iron h and soft iron I + E it drew (MagneticErrors), so the fit must
return b = h and W = (I + E)^-1 scaled to det 1. Cases worked by hand for the
sphere fit and the direction bins; scipy's geometric least squares as an
independent oracle for the ellipsoid fit.
"""

import math

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from tracker import magfit
from tracker.magfit import (BINS, COLLECTING, ELLIPSOID, FITTED, INCONSISTENT, SPHERE, MagFitError,
                            OnlineMagFit, OnlineParams, coverage, fit_ellipsoid, fit_sphere, judge)
from tracker.sim import (Chain, LinkSpec, Motion, SensorSpec, Simulator, realistic_errors,
                         TYPICAL_MAG_DISTURBANCE_UT, TYPICAL_MAG_HARD_IRON_UT, TYPICAL_MAG_SOFT_IRON_PCT)
from tracker import quat

EARTH_UT = math.hypot(20.0, 40.0)  # |tracker.motion.EARTH_FIELD_UT|, 44.72 uT
RATE = 100.0  # the AK8963's continuous mode: 0.6 uT RMS of noise (tracker.sim.MAG_NOISE_RMS_UT)


def tumbling(n: int, seed: int) -> Motion:
    """Sample k held at the k-th of ``n`` uniformly random orientations (scipy): a board turned
    through every orientation (only the magnetometer is read, so the jumps do not matter)."""
    table = Rotation.random(n, random_state=seed).as_quat(scalar_first=True)
    return Motion(lambda t: table[np.clip(np.rint(t * RATE).astype(int), 0, n - 1)],
                  lambda t: np.zeros((len(t), 0)))


def about_one_axis(n: int, wobble_deg: float) -> Motion:
    """The board turned round its own x axis, rocking by up to ``wobble_deg`` about y."""
    def root(t):
        spin = quat.from_axis_angle((1.0, 0.0, 0.0), 2 * np.pi * t / (n / RATE) * 3)
        rock = quat.from_axis_angle((0.0, 1.0, 0.0), np.radians(wobble_deg) * np.sin(2 * np.pi * 1.3 * t))
        return quat.multiply(quat.multiply(quat.from_axis_angle((0.0, 0.0, 1.0), 0.4), spin), rock)
    return Motion(root, lambda t: np.zeros((len(t), 0)))


POLE = Chain((LinkSpec("pole", 0.0),), (SensorSpec("imu", 0, (0.0, 0.0, -0.3)),))  # 0.3 m from a pivot


def board(hard_ut: float, soft_pct: float, disturbance_ut: float, motion: Motion, n: int, seed: int):
    """n readings of the simulated AK8963 on a board with those errors (tracker.sim.realistic_errors)."""
    errors = realistic_errors(mag_hard_iron_ut=hard_ut, mag_soft_iron_pct=soft_pct,
                              mag_disturbance_ut=disturbance_ut)
    return Simulator(POLE, motion, errors, seed=seed).simulate(n / RATE, RATE)


def true_w(soft_iron: np.ndarray) -> np.ndarray:
    """The correction the fit must find: (I + E)^-1 scaled to det 1."""
    w = np.linalg.inv(soft_iron)
    return w / np.linalg.det(w) ** (1 / 3)


# ------------------------------------------------------------------ the sphere, by hand


def test_the_sphere_fit_worked_by_hand():
    # Six readings at +-3, +-4, +-5 uT along the axes about c. The least-squares sphere
    # 2 m.b + k = |m|^2 is symmetric under each axis's reflection, so b = c, and
    # k = B^2 - |b|^2 is the mean of |m - c|^2: B^2 = (9 + 16 + 25) / 3 = 50 / 3.
    c = np.array([7.0, -2.0, 1.0])
    m = c + np.array([[3, 0, 0], [-3, 0, 0], [0, 4, 0], [0, -4, 0], [0, 0, 5], [0, 0, -5]], dtype=float)
    fit = fit_sphere(m, min_coverage=0.0)
    b = math.sqrt(50 / 3)
    assert fit.offset == pytest.approx(c, abs=1e-12)
    assert fit.field_ut == pytest.approx(b, rel=1e-12)
    assert fit.residual_ut == pytest.approx(math.sqrt(((3 - b) ** 2 + (4 - b) ** 2 + (5 - b) ** 2) / 3), rel=1e-9)
    assert fit.soft_iron == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    assert fit.model == SPHERE and fit.readings == 6


def test_points_on_a_known_sphere_give_its_centre_and_radius():
    rng = np.random.default_rng(1)
    u = rng.standard_normal((300, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    c = np.array([120.0, -80.0, 45.0])
    fit = fit_sphere(c + 48.0 * u)
    assert fit.offset == pytest.approx(c, abs=1e-9)
    assert fit.field_ut == pytest.approx(48.0, rel=1e-12)
    assert fit.residual_ut < 1e-9 and fit.coverage == 1.0


# ------------------------------------------------------------------ coverage


def test_the_direction_bins_have_equal_areas():
    # Uniform directions fill each of the 40 bins with 1/40 of them: a binomial count with
    # mean n/40 and standard deviation sqrt(n/40 (1 - 1/40)); every bin within 5 of those.
    n = 400_000
    u = np.random.default_rng(2).standard_normal((n, 3))
    counts = np.bincount(magfit.bin_index(u), minlength=BINS)
    assert len(counts) == BINS == 40
    sd = math.sqrt(n / BINS * (1 - 1 / BINS))
    assert np.abs(counts - n / BINS).max() < 5 * sd


def test_coverage_counts_the_bins_visited():
    assert coverage([[0.0, 0.0, 1.0]] * 10) == 1 / BINS  # one direction, one bin
    assert coverage(np.random.default_rng(3).standard_normal((5000, 3))) == 1.0
    assert coverage(np.zeros((4, 3))) == 0.0  # zero-length rows are ignored
    # A circle of directions (a board turned about one axis) stays under half the sphere.
    rng = np.random.default_rng(4)
    theta = np.linspace(0.0, 2 * math.pi, 3000)
    for _ in range(200):
        a, b = np.linalg.qr(rng.standard_normal((3, 2)))[0].T
        assert coverage(np.outer(np.cos(theta), a) + np.outer(np.sin(theta), b)) < magfit.MIN_COVERAGE


def test_coverage_refuses_bad_input_in_one_line():
    with pytest.raises(MagFitError, match="rows of three"):
        coverage([1.0, 2.0])


# ------------------------------------------------------------------ the ellipsoid, against the simulator


@pytest.mark.parametrize("hard_ut, soft_pct, seed", [(TYPICAL_MAG_HARD_IRON_UT, TYPICAL_MAG_SOFT_IRON_PCT, 1),
                                                      (150.0, 20.0, 2), (200.0, 20.0, 3), (200.0, 10.0, 4)])
def test_the_ellipsoid_fit_recovers_the_boards_hard_and_soft_iron(hard_ut, soft_pct, seed):
    data = board(hard_ut, soft_pct, 0.0, tumbling(2000, seed), 2000, seed)
    fit = fit_ellipsoid(data.mag[:, 0])
    h, s = data.hard_iron[0], data.soft_iron[0]
    assert np.linalg.norm(h) == pytest.approx(hard_ut)
    assert fit.model == ELLIPSOID and fit.coverage == 1.0
    assert np.linalg.norm(np.array(fit.offset) - h) < 1.0  # uT
    w = np.array(fit.soft_iron)
    assert np.abs(w - true_w(s)).max() < 0.01  # of the identity's 1
    assert np.array_equal(w, w.T) and np.linalg.eigvalsh(w).min() > 0 and np.linalg.det(w) == pytest.approx(1.0)
    # W (I + E) R^T m has the strength |m| det(I + E)^(1/3)
    assert fit.field_ut == pytest.approx(EARTH_UT * np.linalg.det(s) ** (1 / 3), abs=0.3)
    assert fit.residual_ut < 1.0  # the AK8963's 0.6 uT of noise, and its 0.15 uT steps
    # the soft iron matters: the sphere alone leaves several uT of it
    sphere = fit_sphere(data.mag[:, 0])
    assert sphere.residual_ut > fit.residual_ut


def test_an_ellipsoid_longer_than_li_and_griffiths_k4_bound_is_still_recovered():
    # Semi-axes 1.6 : 1 : 0.62 (ratio 2.6, beyond the ratio 2 that k = 4 holds at once).
    rng = np.random.default_rng(5)
    turn = Rotation.random(random_state=6).as_matrix()
    s = turn @ np.diag([1.6, 1.0, 0.62]) @ turn.T
    h = np.array([100.0, -50.0, 20.0])
    m = Rotation.random(3000, random_state=7).apply([0.0, 20.0, -40.0]) @ s.T + h + rng.normal(0, 0.6, (3000, 3))
    fit = fit_ellipsoid(m)
    assert np.linalg.norm(np.array(fit.offset) - h) < 0.5
    assert np.abs(np.array(fit.soft_iron) - true_w(s)).max() < 0.01


def test_the_ellipsoid_fit_agrees_with_scipys_geometric_least_squares():
    # The oracle minimises the geometric residual |W (m - b)| - 1 over b and a symmetric W,
    # from a plain start (the mean, the mean radius), with scipy.optimize.least_squares.
    data = board(150.0, 20.0, 0.0, tumbling(1500, 8), 1500, 8)
    m = data.mag[:, 0]

    def unpack(p):
        return p[:3], np.array([[p[3], p[4], p[5]], [p[4], p[6], p[7]], [p[5], p[7], p[8]]])

    def residual(p):
        b, w = unpack(p)
        return np.linalg.norm((m - b) @ w.T, axis=1) - 1.0

    r0 = np.mean(np.linalg.norm(m - m.mean(axis=0), axis=1))
    start = np.concatenate([m.mean(axis=0), [1 / r0, 0, 0, 1 / r0, 0, 1 / r0]])
    b, w = unpack(least_squares(residual, start, xtol=1e-12, ftol=1e-12).x)
    w_det1 = w / np.linalg.det(w) ** (1 / 3)
    fit = fit_ellipsoid(m)
    assert np.array(fit.offset) == pytest.approx(b, abs=0.1)
    assert np.array(fit.soft_iron) == pytest.approx(w_det1, abs=2e-3)
    assert fit.field_ut == pytest.approx(1 / np.linalg.det(w) ** (1 / 3), rel=2e-3)


# ------------------------------------------------------------------ too little, and a field that changes


@pytest.mark.parametrize("wobble_deg", [0.0, 10.0])
def test_a_board_turned_about_one_axis_is_reported_and_not_fitted(wobble_deg):
    data = board(TYPICAL_MAG_HARD_IRON_UT, TYPICAL_MAG_SOFT_IRON_PCT, 0.0, about_one_axis(1500, wobble_deg),
                 1500, 9)
    m = data.mag[:, 0]
    assert coverage(m - data.hard_iron[0]) < magfit.MIN_COVERAGE  # the truth: a band of directions
    for fit in (fit_sphere, fit_ellipsoid):
        with pytest.raises(MagFitError, match="too little coverage") as caught:
            fit(m)
        assert "\n" not in str(caught.value)


def test_readings_over_part_of_the_sphere_fit_the_hard_iron_only():
    # Field directions within 80 deg of one direction: enough for a sphere, too thin for the
    # soft iron's six more parameters.
    data = board(80.0, 0.0, 0.0, tumbling(6000, 10), 6000, 10)
    keep = data.truth.mag[:, 0] @ np.array([0.0, 0.0, 1.0]) / EARTH_UT > math.cos(math.radians(80))
    fit = fit_ellipsoid(data.mag[keep, 0])
    assert magfit.MIN_COVERAGE <= fit.coverage < magfit.ELLIPSOID_COVERAGE
    assert fit.model == SPHERE
    assert np.linalg.norm(np.array(fit.offset) - data.hard_iron[0]) < 1.0  # no soft iron here


def test_a_room_field_that_varies_with_position_gives_a_large_residual():
    # 35 uT of disturbance with a 0.4 m wavelength, sampled over the 0.3 m sphere the board sweeps.
    disturbed = fit_ellipsoid(board(30.0, 5.0, 35.0, tumbling(2000, 11), 2000, 11).mag[:, 0])
    assert disturbed.relative_residual > magfit.MAX_RESIDUAL
    assert judge(disturbed).startswith("the field changes as the board moves")
    for disturbance in (0.0, TYPICAL_MAG_DISTURBANCE_UT):
        fit = fit_ellipsoid(board(30.0, 5.0, disturbance, tumbling(2000, 11), 2000, 11).mag[:, 0])
        assert judge(fit) == ""
        assert disturbed.residual_ut > 3 * fit.residual_ut


def test_a_strength_no_place_on_earth_has_is_judged_inconsistent():
    u = np.random.default_rng(12).standard_normal((500, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    assert "not the earth's" in judge(fit_sphere(300.0 * u))  # a magnet riding on the board
    assert judge(fit_sphere(45.0 * u)) == ""


@pytest.mark.parametrize("bad, message", [([[1.0, 2.0]], "rows of three"), ([["a", 1, 2]], "numbers"),
                                          ([[1.0, 2.0, math.nan]] * 10, "finite"),
                                          ([[1.0, 2.0, 3.0]] * 3, "too few"),
                                          ([[1.0, 2.0, 3.0]] * 30, "all the same")])
def test_bad_readings_get_one_clear_line(bad, message):
    with pytest.raises(MagFitError, match=message) as caught:
        fit_ellipsoid(bad)
    assert "\n" not in str(caught.value)


def test_correct_is_calibrate_in_plain_floats():
    data = board(150.0, 20.0, 0.0, tumbling(1000, 13), 1000, 13)
    fit = fit_ellipsoid(data.mag[:, 0])
    m = data.mag[17, 0]
    assert fit.correct(tuple(m)) == pytest.approx(fit.calibrate(m), abs=1e-12)
    # and calibrated readings are the true field turned into the sensor, scaled by det(I + E)^(1/3)
    scale = np.linalg.det(data.soft_iron[0]) ** (1 / 3)
    assert np.abs(fit.calibrate(data.mag[:, 0]) - scale * data.truth.mag[:, 0]).max() < 5.0
    assert np.sqrt(np.mean((fit.calibrate(data.mag[:, 0]) - scale * data.truth.mag[:, 0]) ** 2)) < 1.0


# ------------------------------------------------------------------ the online collector


def feed(online: OnlineMagFit, m: np.ndarray) -> None:
    for x, y, z in m.tolist():
        online.add((x, y, z))


def test_the_online_fit_matches_the_batch_fit_and_its_memory_stays_bounded():
    data = board(150.0, 20.0, 0.0, tumbling(6000, 14), 6000, 14)
    m = data.mag[:, 0]
    online = OnlineMagFit()
    assert online.fit() is None and online.status == COLLECTING
    feed(online, m)
    kept = online.kept
    assert 500 < kept <= online.params.capacity
    # twenty minutes of one pose held (at 100 Hz) add only the few cubes its noise reaches
    held = board(150.0, 20.0, 0.0, tumbling(1, 14), 120_000, 14).mag[:, 0]
    assert np.ptp(held, axis=0).max() > 2.0  # noise does move it about
    feed(online, held)
    assert online.kept <= kept + 27
    fit = online.fit()
    assert online.status == FITTED and fit is online.result and fit is not None
    batch = fit_ellipsoid(m)
    assert np.array(fit.offset) == pytest.approx(batch.offset, abs=0.3)
    assert np.array(fit.soft_iron) == pytest.approx(np.array(batch.soft_iron), abs=3e-3)
    assert np.linalg.norm(np.array(fit.offset) - data.hard_iron[0]) < 1.0
    assert np.abs(np.array(fit.soft_iron) - true_w(data.soft_iron[0])).max() < 0.01
    assert "calibrated" in online.message


def test_the_online_collector_keeps_at_most_its_capacity_the_newest_cubes():
    online = OnlineMagFit(OnlineParams(cell_ut=1.0, capacity=50))
    for k in range(400):
        online.add((k + 0.5, 0.5, 0.5))  # a new cube each
    assert online.kept == 50
    assert online.readings()[:, 0] == pytest.approx(np.arange(350, 400) + 0.5)
    online.add((math.nan, 0.0, 0.0))  # ignored
    assert online.kept == 50


def test_the_online_collector_forgets_cubes_not_visited_for_a_while():
    online = OnlineMagFit(OnlineParams(cell_ut=1.0, forget_after=100))
    online.add((0.5, 0.5, 0.5))
    for _ in range(150):
        online.add((10.5, 0.5, 0.5))
    assert online.kept == 2
    online.fit()
    assert online.readings().tolist() == [[10.5, 0.5, 0.5]]


def test_the_online_collector_says_when_coverage_is_short_and_when_the_field_is_inconsistent():
    online = OnlineMagFit()
    feed(online, board(30.0, 5.0, 0.0, about_one_axis(1500, 10.0), 1500, 15).mag[:, 0])
    assert online.due
    assert online.fit() is None and online.status == COLLECTING and "too little coverage" in online.message
    assert not online.due  # counted from the fit
    disturbed = OnlineMagFit()
    feed(disturbed, board(30.0, 5.0, 35.0, tumbling(3000, 16), 3000, 16).mag[:, 0])
    assert disturbed.fit() is None and disturbed.status == INCONSISTENT
    assert disturbed.latest is not None and disturbed.latest.relative_residual > magfit.MAX_RESIDUAL
    assert "changes as the board moves" in disturbed.message


def test_online_params_are_checked():
    with pytest.raises(ValueError, match="OnlineParams"):
        OnlineMagFit(OnlineParams(cell_ut=0.0))
