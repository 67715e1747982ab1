"""A real board's errors in the simulator (issue 12): each against a case worked by hand.

Gyroscope warm-up, the AK8963's noise, hard and soft iron, the room's field
disturbance, the flex sensor's nonlinearity, hysteresis and creep, and a
stream's blocks equal to the batch with all of them on.
"""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tracker import quat
from tracker.flex import FULL_BEND_DEG, adc_from_degrees
from tracker.mpu_dlpf import Dlpf
from tracker.sim import (MAG_NOISE_DENSITY, TYPICAL_FLEX_CREEP_PCT, TYPICAL_FLEX_HYSTERESIS_PCT,
                         TYPICAL_FLEX_NONLINEARITY_PCT, TYPICAL_GYRO_BIAS_DPS, TYPICAL_GYRO_WARMUP_DPS,
                         TYPICAL_MAG_DISTURBANCE_UT, TYPICAL_MAG_HARD_IRON_UT, TYPICAL_MAG_SOFT_IRON_PCT,
                         Chain, ErrorModel, FlexDynamics, LinkSpec, MagneticErrors, Motion, SensorErrors,
                         SensorSpec, Simulator, arm_chain, arm_source, arm_swing, mpu9250, realistic_errors)

EARTH = np.array([0.0, 20.0, -40.0])  # tracker.motion.EARTH_FIELD_UT
SPAN = FULL_BEND_DEG  # the default flex sensor's straight-to-bent span, degrees


def still(angle_deg: float = 0.0) -> Motion:
    """The arm hanging still, the elbow at ``angle_deg``."""
    return Motion(lambda t: np.broadcast_to([1.0, 0.0, 0.0, 0.0], (len(t), 4)),
                  lambda t: np.full((len(t), 1), math.radians(angle_deg)))


def elbow(degrees_of_t) -> Motion:
    """The upper arm still, the elbow following ``degrees_of_t``."""
    return Motion(lambda t: np.broadcast_to([1.0, 0.0, 0.0, 0.0], (len(t), 4)),
                  lambda t: np.radians(degrees_of_t(t))[:, None])


def tumbling(n: int, rate: float, seed: int) -> Motion:
    """Sample k held at the k-th of ``n`` uniformly random orientations (scipy): the board turned
    through every orientation. Only the magnetometer is read, so the jumps between samples do not
    matter (the simulator's stencil stays within one sample's orientation)."""
    table = Rotation.random(n, random_state=seed).as_quat(scalar_first=True)
    return Motion(lambda t: table[np.clip(np.rint(t * rate).astype(int), 0, n - 1)],
                  lambda t: np.zeros((len(t), 0)))


def pole(radius_m: float) -> Chain:
    """A root of no length carrying one sensor ``radius_m`` along its -z: it sweeps a sphere."""
    return Chain((LinkSpec("pole", 0.0),), (SensorSpec("imu", 0, (0.0, 0.0, -radius_m)),))


# ------------------------------------------------------------------ gyroscope warm-up


def test_the_warm_up_curve_worked_by_hand():
    warmup, tau, rate = math.radians(2.0), 100.0, 10.0
    errors = SensorErrors(gyr=ErrorModel(warmup=warmup, warmup_tau_s=tau))
    data = Simulator(arm_chain(), still(), errors, seed=3).simulate(700.0, rate)
    e = (data.gyr - data.truth.gyr)[:, 0]
    u = data.warmup["gyr"][0] / warmup
    assert np.linalg.norm(u) == pytest.approx(1.0)  # a drawn direction, unit
    assert np.abs(u).min() > 0.01
    norm = 1 - math.exp(-600.0 / tau)
    assert e[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-15)  # power-on: no change yet
    assert e[int(tau * rate)] == pytest.approx(warmup * u * (1 - math.exp(-1)) / norm, rel=1e-9)  # 63.2 %
    assert e[6000] == pytest.approx(warmup * u, rel=1e-9)  # exactly the change after 600 s
    assert np.linalg.norm(e[6000]) == pytest.approx(warmup, rel=1e-9)
    t = data.t
    assert e == pytest.approx(np.outer((1 - np.exp(-t / tau)) / norm, warmup * u), abs=1e-12)
    other = Simulator(arm_chain(), still(), errors, seed=4).simulate(1.0, rate)
    assert not np.allclose(other.warmup["gyr"], data.warmup["gyr"])


def test_the_warm_up_adds_to_the_drawn_offset_and_leaves_the_other_draws_alone():
    plain = mpu9250()
    warm = replace(plain, gyr=replace(plain.gyr, warmup=math.radians(1.0)))
    a = Simulator(arm_chain(), arm_swing(), plain, seed=9).simulate(20.0, 200.0)
    b = Simulator(arm_chain(), arm_swing(), warm, seed=9).simulate(20.0, 200.0)
    assert np.array_equal(a.offset["gyr"], b.offset["gyr"])
    assert np.array_equal(a.acc, b.acc) and np.array_equal(a.mag, b.mag)
    curve = (1 - np.exp(-a.t / 150.0)) / (1 - math.exp(-600.0 / 150.0))
    lsb = plain.gyr.resolution
    assert np.abs(b.gyr - a.gyr - curve[:, None, None] * b.warmup["gyr"]).max() <= lsb + 1e-12


def test_a_board_on_for_a_while_is_that_far_along_its_warm_up_and_its_die_that_warm():
    # powered_s = P: sample k is where a board just powered up is at k / rate + P, the draws unchanged
    errors = realistic_errors(gyro_warmup_dps=3.0)
    fresh = Simulator(arm_chain(), still(), errors, seed=6).simulate(400.0, 10.0)
    later = Simulator(arm_chain(), still(), errors, seed=6, powered_s=300.0).simulate(100.0, 10.0)
    np.testing.assert_array_equal(later.die_c, fresh.die_c[3000:])
    np.testing.assert_array_equal(later.warmup["gyr"], fresh.warmup["gyr"])
    # the warm-up part of the gyroscope's error (the noise is drawn per sample index, so compare the curve's)
    tau, norm = 150.0, 1 - math.exp(-600.0 / 150.0)
    shifted = (1 - np.exp(-(later.t + 300.0) / tau)) / norm
    lsb, noise = errors.gyr.resolution, (later.gyr - later.truth.gyr)[:, 0] - shifted[:, None] * later.warmup["gyr"][0]
    assert np.abs(noise.mean(axis=0) - later.offset["gyr"][0]).max() < 0.1 * np.abs(later.warmup["gyr"][0]).max() + lsb


def test_a_warm_up_without_a_time_constant_is_a_clear_error():
    errors = SensorErrors(gyr=ErrorModel(warmup=0.01, warmup_tau_s=0.0))
    with pytest.raises(ValueError, match="warm-up needs a time constant above 0 s"):
        Simulator(arm_chain(), still(), errors).simulate(1.0, 10.0)


# ------------------------------------------------------------------ magnetometer


@pytest.mark.parametrize("rate", [100.0, 200.0, 250.0])
def test_the_ak8963_measures_at_100_hz_with_its_noise_and_the_board_holds_each_reading(rate):
    data = Simulator(arm_chain(), still(), mpu9250(offset=False), seed=5).simulate(60.0, rate)
    mag = data.mag[:, 0]
    # Its ticks at m / 100 s, each read at the first sample at or after it: worked by hand, samples
    # 0, 2, 4, ... at 200 Hz; at 250 Hz (4 ms apart) samples 0, 3, 5, 8, 10, ... (ticks at 0, 10, 20, 30 ms).
    t = np.arange(len(mag)) / rate
    first = np.ceil(np.floor(t * 100.0 + 1e-9) / 100.0 * rate - 1e-9).astype(int)
    assert first[:11].tolist() == {100.0: list(range(11)), 200.0: [0, 0, 2, 2, 4, 4, 6, 6, 8, 8, 10],
                                   250.0: [0, 0, 0, 3, 3, 5, 5, 5, 8, 8, 10]}[rate]
    assert np.array_equal(mag, mag[first])  # every sample carries its tick's reading
    readings = mag[np.unique(first)]
    assert len(readings) == pytest.approx(60.0 * 100.0, abs=1)
    # ... and each reading has the noise of one measurement at 100 Hz: 0.6 uT RMS (MAG_NOISE_RMS_UT),
    # with the 0.15 uT counts' rounding.
    e = readings - data.truth.mag[np.unique(first), 0]
    std = MAG_NOISE_DENSITY * math.sqrt(100.0)
    assert std == pytest.approx(0.6)
    assert e.std(axis=0) == pytest.approx([math.sqrt(std**2 + 0.15**2 / 12)] * 3, rel=0.03)
    assert abs(np.corrcoef(e[1:, 0], e[:-1, 0])[0, 1]) < 0.05  # reading to reading: independent


def test_hard_iron_shifts_the_centre_of_the_field_sphere_by_exactly_h():
    n, rate = 400, 50.0
    for seed in (1, 2):
        errors = SensorErrors(magnetic=MagneticErrors(hard_iron_ut=50.0))
        data = Simulator(pole(0.3), tumbling(n, rate, seed), errors, seed=seed).simulate(n / rate, rate)
        x = data.mag[:, 0]
        # |x - c|^2 = r^2  <=>  2 x.c + (r^2 - |c|^2) = |x|^2: linear least squares in (c, r^2 - |c|^2)
        a = np.column_stack([2 * x, np.ones(n)])
        sol = np.linalg.lstsq(a, np.sum(x * x, axis=1), rcond=None)[0]
        centre = sol[:3]
        radius = math.sqrt(sol[3] + centre @ centre)
        assert centre == pytest.approx(data.hard_iron[0], abs=1e-9)
        assert np.linalg.norm(centre) == pytest.approx(50.0, rel=1e-12)
        assert radius == pytest.approx(np.linalg.norm(EARTH), rel=1e-12)  # 44.72 uT, the earth's field
        assert np.array_equal(data.soft_iron[0], np.eye(3))


def test_soft_iron_maps_the_sphere_to_the_ellipsoid_of_i_plus_e():
    n, rate, bound = 400, 50.0, 0.15
    errors = SensorErrors(magnetic=MagneticErrors(soft_iron=bound))
    data = Simulator(pole(0.3), tumbling(n, rate, 7), errors, seed=7).simulate(n / rate, rate)
    s = data.soft_iron[0]
    e = s - np.eye(3)
    assert np.array_equal(s, s.T) and np.abs(e).max() <= bound and np.abs(e).max() > bound / 3
    x = data.mag[:, 0]
    # x = S v with |v| = |m|: x^T A x = 1 with A = S^-2 / |m|^2. Fit the six entries of A.
    rows = np.column_stack([x[:, 0]**2, x[:, 1]**2, x[:, 2]**2, 2 * x[:, 0] * x[:, 1],
                            2 * x[:, 0] * x[:, 2], 2 * x[:, 1] * x[:, 2]])
    a00, a11, a22, a01, a02, a12 = np.linalg.lstsq(rows, np.ones(n), rcond=None)[0]
    fitted = np.array([[a00, a01, a02], [a01, a11, a12], [a02, a12, a22]])
    semi_axes = 1 / np.sqrt(np.linalg.eigvalsh(fitted))
    predicted = np.linalg.norm(EARTH) * np.linalg.eigvalsh(s)  # S symmetric: axes |m| eig(S)
    assert np.sort(semi_axes) == pytest.approx(np.sort(predicted), rel=1e-9)
    assert np.array_equal(data.hard_iron, np.zeros((1, 3)))


def test_the_room_disturbance_is_bounded_near_zero_mean_and_varies_on_its_scale():
    # A sensor 3 m out, turned through uniformly random orientations, samples the field on a
    # sphere 15 wavelengths across. Pairs of points delta apart in uniformly random directions see
    # the correlation of a plane wave averaged over directions: sin(k delta) / (k delta), k = 2 pi/l.
    n, rate, bound, wavelength = 3000, 100.0, 20.0, 0.4
    errors = SensorErrors(magnetic=MagneticErrors(disturbance_ut=bound, disturbance_scale_m=wavelength))
    data = Simulator(pole(3.0), tumbling(n, rate, 1), errors, seed=2).simulate(n / rate, rate)
    d = quat.rotate(data.truth.q_sensors[:, 0], data.mag[:, 0]) - EARTH  # the disturbance, world frame
    p = data.truth.p_sensors[:, 0]
    assert np.linalg.norm(p, axis=1) == pytest.approx(np.full(n, 3.0))
    size = np.linalg.norm(d, axis=1)
    assert size.max() <= bound + 1e-9 and size.max() > bound / 2
    assert np.linalg.norm(d.mean(axis=0)) < 0.05 * bound
    k = 2 * math.pi / wavelength
    distance = np.linalg.norm(p[:, None] - p[None], axis=-1)
    dots, power = d @ d.T, np.mean(size**2)
    for delta in (wavelength / 4, wavelength / 2, 0.7 * wavelength):
        band = np.abs(distance - delta) < 0.01
        assert dots[band].mean() / power == pytest.approx(math.sin(k * delta) / (k * delta), abs=0.12)
    # and never steeper than its modes allow: |d(p) - d(q)| <= bound k |p - q|
    step = np.linalg.norm(np.diff(d, axis=0), axis=1)
    assert np.all(step <= bound * k * np.linalg.norm(np.diff(p, axis=0), axis=1) + 1e-9)


def test_the_room_disturbance_has_no_divergence():
    # Gauss's law for magnetism: div d = 0. Six sensors h apart around a centre 1 m out give it by
    # central differences (error about h^2 k^3 bound / 6, 1e-5 of the gradient k bound).
    n, rate, bound, wavelength, h = 200, 50.0, 20.0, 0.4, 1e-3
    at = np.array([0.0, 0.0, -1.0]) + np.vstack([np.eye(3) * h, -np.eye(3) * h])
    chain = Chain((LinkSpec("pole", 0.0),), tuple(SensorSpec(f"s{i}", 0, tuple(p)) for i, p in enumerate(at)))
    errors = SensorErrors(magnetic=MagneticErrors(disturbance_ut=bound, disturbance_scale_m=wavelength))
    data = Simulator(chain, tumbling(n, rate, 4), errors, seed=8).simulate(n / rate, rate)
    d = quat.rotate(data.truth.q_sensors, data.mag) - EARTH  # (n, 6, 3), world frame
    axes = data.truth.p_sensors[:, :3] - data.truth.p_sensors[:, 3:]  # 2 h along each turned axis
    divergence = np.sum((d[:, :3] - d[:, 3:]) * axes, axis=(1, 2)) / (4 * h * h)
    gradient = bound * 2 * math.pi / wavelength
    assert np.abs(divergence).max() < 1e-3 * gradient
    assert np.abs(d[:, 0] - d[:, 3]).max() > 1e-3 * gradient * 2 * h  # the field does change there


def test_magnetic_errors_touch_only_the_magnetometer():
    base = mpu9250()
    worn = SensorErrors(base.gyr, base.acc, base.mag,
                        magnetic=MagneticErrors(hard_iron_ut=40.0, soft_iron=0.1, disturbance_ut=10.0))
    a = Simulator(arm_chain(), arm_swing(), base, seed=6).simulate(5.0, 200.0)
    b = Simulator(arm_chain(), arm_swing(), worn, seed=6).simulate(5.0, 200.0)
    assert np.array_equal(a.gyr, b.gyr) and np.array_equal(a.acc, b.acc)
    assert np.array_equal(a.flex_adc, b.flex_adc) and np.array_equal(a.truth.mag, b.truth.mag)
    assert np.abs(a.mag - b.mag).max() > 10.0


# ------------------------------------------------------------------ flex sensor


def test_the_hysteresis_loop_is_hysteresis_times_the_span_wide():
    # The elbow bends 0 -> 90 -> 0 over 40 s: 45 (1 - cos(2 pi t / 40)), 45 degrees at 10 s rising
    # and at 30 s falling. The play operator reads r = width / 2 low rising and r high falling.
    hysteresis, rate = 0.06, 100.0
    errors = SensorErrors(flex_dynamics=FlexDynamics(hysteresis=hysteresis))
    motion = elbow(lambda t: 45.0 * (1 - np.cos(2 * np.pi * t / 40.0)))
    data = Simulator(arm_chain(), motion, errors).simulate(40.0, rate)
    up, down = data.flex_reading_deg[1000], data.flex_reading_deg[3000]
    assert data.truth.flex_deg[[1000, 3000]] == pytest.approx([45.0, 45.0])
    assert down - up == pytest.approx(hysteresis * SPAN, rel=1e-9)  # 7.62 degrees
    assert up == pytest.approx(45.0 - hysteresis * SPAN / 2, rel=1e-9)
    assert data.flex_reading_deg[0] == 0.0  # within the play: still reads straight
    assert np.all(np.abs(data.flex_reading_deg - data.truth.flex_deg) <= hysteresis * SPAN / 2 + 1e-9)
    assert np.array_equal(data.flex_adc, adc_from_degrees(data.flex_reading_deg))  # what the circuit reads


def test_creep_relaxes_a_held_bend_as_a_first_order_lag():
    creep, tau, bend, rate = 0.08, 4.0, 70.0, 50.0
    errors = SensorErrors(flex_dynamics=FlexDynamics(creep=creep, creep_tau_s=tau))
    data = Simulator(arm_chain(), still(bend), errors).simulate(30.0, rate)
    relaxed = creep * SPAN * (bend / SPAN) * (1 - np.exp(-data.t / tau))  # reads less bent
    assert data.flex_reading_deg == pytest.approx(bend - relaxed, abs=1e-9)
    assert bend - data.flex_reading_deg[int(tau * rate)] == pytest.approx(creep * bend * (1 - math.exp(-1)))
    straight = Simulator(arm_chain(), still(0.0), errors).simulate(5.0, rate)
    assert np.array_equal(straight.flex_reading_deg, straight.truth.flex_deg)  # nothing to relax


def test_the_nonlinearity_is_a_smooth_bow_zero_at_both_ends_with_its_peak():
    peak, rate = 0.05, 100.0
    errors = SensorErrors(flex_dynamics=FlexDynamics(nonlinearity=peak))
    ramp = elbow(lambda t: SPAN * np.clip(t / 10.0, 0.0, 1.0))  # straight to fully bent over 10 s
    for seed in (0, 1, 2):
        data = Simulator(arm_chain(), ramp, errors, seed=seed).simulate(10.01, rate)
        x, y = data.truth.flex_deg, data.flex_reading_deg
        dev = y - x
        assert dev[[0, -1]] == pytest.approx([0.0, 0.0], abs=1e-12)  # x = 0 and x = span
        assert np.abs(dev).max() <= peak * SPAN + 1e-9
        assert np.abs(dev).max() == pytest.approx(peak * SPAN, rel=1e-3)  # 6.35 degrees
        u = x / SPAN  # a combination of sin(pi u) and sin(2 pi u), nothing else
        basis = np.column_stack([np.sin(np.pi * u), np.sin(2 * np.pi * u)])
        fit = np.linalg.lstsq(basis, dev, rcond=None)[0]
        assert basis @ fit == pytest.approx(dev, abs=1e-9)
        assert np.all(np.diff(y) > 0)  # still monotonic


def test_bad_flex_dynamics_are_clear_errors():
    with pytest.raises(ValueError, match=r"nonlinearity must lie in \[0, 1/\(2 pi\)\)"):
        Simulator(arm_chain(), still(), SensorErrors(flex_dynamics=FlexDynamics(nonlinearity=0.2))) \
            .simulate(0.1, 10.0)
    with pytest.raises(ValueError, match="creep needs a time constant above 0 s"):
        Simulator(arm_chain(), still(), SensorErrors(flex_dynamics=FlexDynamics(creep=0.05, creep_tau_s=0))) \
            .simulate(0.1, 10.0)


# ------------------------------------------------------------------ streams and the typical board


def _every_field_equal(block, data, rows) -> None:
    for name in ("t", "gyr", "acc", "mag", "flex_adc", "flex_reading_deg"):
        assert np.array_equal(getattr(block, name), getattr(data, name)[rows]), name
    assert np.array_equal(block.truth.p_sensors, data.truth.p_sensors[rows])


def test_blocks_with_every_error_on_are_the_rows_of_the_batch_in_and_out_of_order():
    errors = realistic_errors(flex_hysteresis_pct=8.0, flex_creep_pct=6.0, mag_disturbance_ut=20.0)
    sim = Simulator(arm_chain(), arm_swing(), errors, seed=12)
    data = sim.simulate(50.0, 200.0)  # 10000 samples: the flex states kept at 4096 and 8192
    stream, edges = sim.stream(200.0), np.cumsum([0, 1, 7, 50, 333, 4096, 2, 511, 3000, 2000])
    blocks = [stream.block(int(k0), int(k1)) for k0, k1 in zip(edges[:-1], edges[1:])]
    for name in ("gyr", "mag", "flex_adc", "flex_reading_deg"):
        assert np.array_equal(np.concatenate([getattr(b, name) for b in blocks]), getattr(data, name)[:10000])
    for k0, k1 in ((4000, 4100), (100, 300), (9000, 9100), (5000, 5200), (5100, 5300), (0, 10)):
        _every_field_equal(stream.block(k0, k1), data, slice(k0, k1))  # back, forward, overlapping
    fresh = sim.stream(200.0)  # a stream that starts late computes the flex history it needs
    _every_field_equal(fresh.block(9500, 9600), data, slice(9500, 9600))
    assert np.array_equal(blocks[0].hard_iron, data.hard_iron)
    assert np.array_equal(blocks[0].soft_iron, data.soft_iron)


@pytest.mark.parametrize("dlpf", [False, True])
def test_a_block_restarting_inside_the_last_needs_no_earlier_motion(dlpf):
    # The simulated board computes samples ahead and, when the motion is edited, computes again
    # from the first edited sample; the bot's motion forgets what is long past. Resuming inside
    # the last block must not ask the motion for times before that block (and, through the
    # MPU-9250's low-pass filters, its few samples before: tracker.mpu_dlpf).
    asked = []
    base = arm_swing()

    def joints(t):
        asked.append(float(np.min(t)))
        return base.joints(t)

    errors = SensorErrors(flex_dynamics=FlexDynamics(hysteresis=0.05, creep=0.05), dlpf=dlpf)
    sim = Simulator(arm_chain(), Motion(base.root, joints), errors, seed=3)
    data = sim.simulate(5.0, 200.0)
    stream = sim.stream(200.0)
    stream.block(0, 200)
    stream.block(200, 400)
    asked.clear()
    _every_field_equal(stream.block(300, 500), data, slice(300, 500))
    # Through the filters a reading weighs the chip's internal samples back to 50 ms before it.
    reach = (max(Dlpf.for_rate(200.0).gyro.taps, Dlpf.for_rate(200.0).accel.taps) - 1) / 1000.0 if dlpf else 0.0
    assert 0.0 <= reach <= 0.05
    assert min(asked) >= 300 / 200.0 - reach - 0.001  # no earlier than that (and its 1 ms stencil)


def test_realistic_errors_take_the_profile_units_and_the_typical_board_is_the_default():
    e = realistic_errors(gyro_bias_dps=2.0, noise_scale=3.0, gyro_warmup_dps=1.5, mag_hard_iron_ut=80.0,
                         mag_soft_iron_pct=10.0, mag_disturbance_ut=25.0, flex_hysteresis_pct=6.0,
                         flex_creep_pct=5.0, flex_nonlinearity_pct=3.0)
    base = mpu9250()
    assert e.gyr.offset_max == pytest.approx(math.radians(2.0))
    assert e.gyr.warmup == pytest.approx(math.radians(1.5))
    # The die warms by 1.5 / 0.24 = 6.25 degC, so the zero-g level by 1.5 mg x 6.25 = 9.375 mg.
    assert e.acc.warmup == pytest.approx(9.375e-3 * 9.80665)
    assert e.acc.warmup_unexplained == e.gyr.warmup_unexplained
    for kind in ("gyr", "acc", "mag"):
        assert getattr(e, kind).noise_density == pytest.approx(3.0 * getattr(base, kind).noise_density)
        assert getattr(e, kind).resolution == getattr(base, kind).resolution
    assert e.magnetic == MagneticErrors(hard_iron_ut=80.0, soft_iron=0.10, disturbance_ut=25.0)
    assert e.flex_dynamics == FlexDynamics(hysteresis=0.06, creep=0.05, nonlinearity=0.03)
    typical = realistic_errors()
    assert typical == realistic_errors(TYPICAL_GYRO_BIAS_DPS, 1.0, TYPICAL_GYRO_WARMUP_DPS,
                                       TYPICAL_MAG_HARD_IRON_UT, TYPICAL_MAG_SOFT_IRON_PCT,
                                       TYPICAL_MAG_DISTURBANCE_UT, TYPICAL_FLEX_HYSTERESIS_PCT,
                                       TYPICAL_FLEX_CREEP_PCT, TYPICAL_FLEX_NONLINEARITY_PCT)
    assert arm_source().sim.errors == typical  # the virtual board wears the typical board


def test_the_virtual_boards_default_wearer_shows_the_typical_errors():
    source = arm_source(rate_hz=200.0, seed=1)
    data = source.sim.simulate(10.0, 200.0)
    assert np.linalg.norm(data.hard_iron[0]) == pytest.approx(TYPICAL_MAG_HARD_IRON_UT)
    lag = np.abs(data.flex_reading_deg - data.truth.flex_deg)
    assert lag.max() > TYPICAL_FLEX_HYSTERESIS_PCT / 100 * SPAN / 2  # the elbow's reading lags
    assert lag.max() < (TYPICAL_FLEX_HYSTERESIS_PCT / 2 + TYPICAL_FLEX_CREEP_PCT
                        + TYPICAL_FLEX_NONLINEARITY_PCT) / 100 * SPAN + 1e-9
    r = source.reading(2.0)
    assert r.flex_adc == data.flex_adc[400] and r.mag == tuple(data.mag[400, 0])
