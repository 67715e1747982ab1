"""The sensor simulator against motions worked by hand, scipy's rotations and the finger chain of
Inertial Sensor Based Solution for Finger Motion Tracking (Computers 9(2):40, 2020)."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tracker import protocol as P
from tracker import quat
from tracker.board import BoardSettings, VirtualBoard, quantise
from tracker.flex import FULL_BEND_DEG, FlexCircuit, adc_from_degrees
from tracker.link import Link, LinkSettings
from tracker.sim import (ACC_NOISE_DENSITY, GYR_NOISE_DENSITY, GYR_OFFSET_MAX, Chain, ErrorModel,
                         Motion, SensorErrors, SensorSpec, SimulatedSource, Simulator,
                         arm_chain, arm_swing, finger_chain, grasp, mpu9250)

from .helpers import wire

G = 9.81
EARTH = np.array([0.0, 20.0, -40.0])


def rot(q: np.ndarray) -> Rotation:
    return Rotation.from_quat(q, scalar_first=True)


def still(q0, angles=(0.0,)) -> Motion:
    """A fixed pose: root orientation q0 and constant joint angles (radians)."""
    return Motion(lambda t: np.broadcast_to(np.asarray(q0, float), (len(t), 4)),
                  lambda t: np.broadcast_to(np.asarray(angles, float), (len(t), len(angles))))


def spin(axis_angle_rate, q0=(1.0, 0.0, 0.0, 0.0), then=(1.0, 0.0, 0.0, 0.0)) -> Motion:
    """The root turning as q0 * exp(w t) * then: a constant body rate w about a fixed axis."""
    w = np.asarray(axis_angle_rate, float)
    return Motion(lambda t: quat.multiply(quat.multiply(q0, quat.from_rotvec(t[:, None] * w)), then),
                  lambda t: np.zeros((len(t), 1)))


def test_a_constant_body_rate_reads_as_that_rate():
    w = np.array([0.4, -1.3, 2.2])
    q0 = quat.from_euler([0.3, -0.7, 1.9], "ZYX")
    data = Simulator(arm_chain(), spin(w, q0)).simulate(2.0, 100.0)
    assert data.truth.gyr[:, 0] == pytest.approx(np.broadcast_to(w, (200, 3)), abs=1e-8)
    assert np.array_equal(data.gyr, data.truth.gyr)  # ideal sensors by default


def test_integrating_the_gyroscopes_reproduces_the_orientations():
    chain = arm_chain()
    mount = tuple(quat.from_euler([0.2, 0.5, -0.4], "ZYX"))  # a crooked forearm sensor
    chain = Chain(chain.links, chain.sensors + (SensorSpec("fore", 1, (0.0, 0.02, -0.2), mount),), 1)
    sim, rate, seconds = Simulator(chain, arm_swing()), 2000.0, 3.0
    n = int(seconds * rate)
    mid = sim.truth((np.arange(n) + 0.5) / rate).gyr  # rates at the middle of each step
    ends = sim.truth([0.0, seconds]).q_sensors
    for s in range(2):
        r = rot(ends[0, s])
        for step in Rotation.from_rotvec(mid[:, s] / rate):
            r = r * step  # body rates compose on the right
        assert (r.inv() * rot(ends[1, s])).magnitude() < 1e-5


def test_the_forearm_rate_is_the_upper_arm_rate_turned_plus_the_elbow_rate():
    chain = arm_chain()
    chain = Chain(chain.links, chain.sensors + (SensorSpec("fore", 1, (0.0, 0.0, -0.1)),), 1)
    t = np.linspace(0, 6, 50)
    truth = Simulator(chain, arm_swing()).truth(t)
    elbow, elbow_rate = np.radians(55) * (1 - np.cos(2 * np.pi * t / 3)), \
        np.radians(55) * 2 * np.pi / 3 * np.sin(2 * np.pi * t / 3)
    turned = Rotation.from_rotvec(elbow[:, None] * [0, 1, 0]).inv().apply(truth.gyr[:, 0])
    assert truth.gyr[:, 1] == pytest.approx(turned + elbow_rate[:, None] * [0, 1, 0], abs=1e-8)
    assert truth.flex_deg == pytest.approx(np.degrees(elbow))


def test_a_still_pose_feels_gravity_up_and_the_earth_field():
    rs = Rotation.random(5, random_state=3)
    for r in rs:
        truth = Simulator(arm_chain(), still(r.as_quat(scalar_first=True), (0.8,))).truth([0.0, 1.0])
        assert truth.acc[:, 0] == pytest.approx(np.tile(r.inv().apply([0, 0, G]), (2, 1)), abs=1e-7)
        assert truth.mag[:, 0] == pytest.approx(np.tile(r.inv().apply(EARTH), (2, 1)), abs=1e-9)
        assert truth.gyr == pytest.approx(np.zeros((2, 1, 3)), abs=1e-9)


def test_a_circular_motion_feels_omega_squared_r_by_hand():
    # The arm held out horizontally along +x (a -90 degree turn about y), whirled about the
    # vertical at 1 turn/s: the sensor 0.30 m out feels w^2 r = 4 pi^2 0.3 = 11.84 m/s^2 toward
    # the axis, which is its +z (its -z runs along the arm), and gravity along its +x (up).
    horizontal = quat.from_axis_angle([0, 1, 0], -np.pi / 2)
    w = 2 * np.pi
    motion = Motion(lambda t: quat.multiply(quat.from_axis_angle([0, 0, 1], w * t), horizontal),
                    lambda t: np.zeros((len(t), 1)))
    truth = Simulator(arm_chain(), motion).truth(np.linspace(0, 1, 17))
    assert truth.acc[:, 0] == pytest.approx(np.tile([G, 0, 4 * np.pi**2 * 0.30], (17, 1)), abs=1e-6)
    assert truth.gyr[:, 0] == pytest.approx(np.tile([w, 0, 0], (17, 1)), abs=1e-8)


def test_a_swinging_pendulum_feels_tangential_and_centripetal_acceleration():
    # The hanging arm swings about y: theta = A sin(W t). At r = 0.30 m the sensor feels
    # (-r theta'' - g sin theta, 0, r theta'^2 + g cos theta) in its own frame.
    A, W, r = 0.7, 3.0, 0.30
    motion = Motion(lambda t: quat.from_axis_angle([0, 1, 0], A * np.sin(W * t)),
                    lambda t: np.zeros((len(t), 1)))
    t = np.linspace(0, 4, 81)
    th, th1, th2 = A * np.sin(W * t), A * W * np.cos(W * t), -A * W * W * np.sin(W * t)
    expected = np.stack([-r * th2 - G * np.sin(th), 0 * t, r * th1**2 + G * np.cos(th)], axis=-1)
    assert Simulator(arm_chain(), motion).truth(t).acc[:, 0] == pytest.approx(expected, abs=1e-6)


def rocking(amplitude, omega, pivot=(0.0, 0.0, 0.0)) -> Motion:
    """The hanging arm held still, elbow at 0.4 rad, the board rocking on it about its link's x
    by theta = amplitude sin(omega t) about ``pivot`` (from the sensor, link frame)."""
    return Motion(still((1.0, 0.0, 0.0, 0.0), (0.4,)).root, still((1.0, 0.0, 0.0, 0.0), (0.4,)).joints,
                  mount=lambda t: quat.from_axis_angle([1, 0, 0], amplitude * np.sin(omega * t)),
                  mount_pivot_m=pivot)


def test_a_board_rocking_on_its_link_about_a_point_under_it_by_hand():
    # theta = A sin(W t) about x through c = (0, -r, 0) from the sensor: the sensor sits at
    # (0, 0, -L) + c - R_x(theta) c = (0, 0, -L) + r (0, cos theta - 1, sin theta), so
    # p'' = r (0, -cos theta th'^2 - sin theta th'', cos theta th'' - sin theta th'^2); it
    # turns at (th', 0, 0) and feels R_x(theta)^T (p'' + (0, 0, g)). A rocking of 2 deg at
    # 12 Hz turns it at up to 2 pi 12 A = 151 deg/s and accelerates it by about W^2 A r, not
    # by W^2 A L as turning the whole 0.3 m arm would.
    A, W, r, L = np.radians(2.0), 2 * np.pi * 12.0, 0.04, 0.30
    t = np.linspace(0, 0.25, 401)
    th, th1, th2 = A * np.sin(W * t), A * W * np.cos(W * t), -A * W * W * np.sin(W * t)
    truth = Simulator(arm_chain(), rocking(A, W, (0.0, -r, 0.0))).truth(t)
    # (the 5-point stencil's truncation, h^4 / 30 W^5 A, is 2e-7 rad/s at 12 Hz)
    assert truth.gyr[:, 0] == pytest.approx(np.stack([th1, 0 * t, 0 * t], -1), abs=1e-6)
    assert np.degrees(np.abs(truth.gyr[:, 0, 0]).max()) == pytest.approx(2 * np.pi * 12.0 * 2.0, rel=1e-3)
    p = np.stack([0 * t, r * (np.cos(th) - 1), r * np.sin(th) - L], -1)
    assert truth.p_sensors[:, 0] == pytest.approx(p, abs=1e-12)
    p2 = r * np.stack([0 * t, -np.cos(th) * th1**2 - np.sin(th) * th2, np.cos(th) * th2 - np.sin(th) * th1**2], -1)
    expected = Rotation.from_rotvec(th[:, None] * [1, 0, 0]).inv().apply(p2 + [0, 0, G])
    assert truth.acc[:, 0] == pytest.approx(expected, abs=1e-6)
    lever = np.linalg.norm(p2, axis=1).max()
    assert lever == pytest.approx(W**2 * A * r, rel=0.01) and lever < W**2 * A * L / 5
    # the link and what hangs on it (the forearm at the elbow's 0.4 rad) do not rock
    assert np.array_equal(truth.q_links[:, 0], np.tile([1.0, 0, 0, 0], (len(t), 1)))
    assert rot(truth.q_links[:, 1]).approx_equal(Rotation.from_rotvec([0, 0.4, 0]), atol=1e-15).all()


def test_a_board_rocking_about_itself_only_turns():
    A, W = np.radians(3.0), 2 * np.pi * 9.0
    t = np.linspace(0, 0.3, 101)
    truth = Simulator(arm_chain(), rocking(A, W)).truth(t)
    assert np.array_equal(truth.p_sensors[:, 0], np.tile([0.0, 0.0, -0.30], (len(t), 1)))
    th = A * np.sin(W * t)
    assert truth.acc[:, 0] == pytest.approx(Rotation.from_rotvec(th[:, None] * [1, 0, 0]).inv().apply([0, 0, G]),
                                            abs=1e-6)
    assert truth.gyr[:, 0, 0] == pytest.approx(A * W * np.cos(W * t), abs=1e-6)


def test_an_identity_mount_changes_nothing_bit_for_bit():
    plain = Simulator(arm_chain(), arm_swing(), mpu9250(), seed=2).simulate(2.0, 100.0)
    swing = arm_swing()
    mounted = Motion(swing.root, swing.joints, mount=lambda t: quat.identity((len(t),)),
                     mount_pivot_m=(0.01, -0.05, 0.02))
    same = Simulator(arm_chain(), mounted, mpu9250(), seed=2).simulate(2.0, 100.0)
    for name in ("gyr", "acc", "mag", "flex_adc"):
        assert np.array_equal(getattr(plain, name), getattr(same, name))
    assert np.array_equal(plain.truth.p_sensors, same.truth.p_sensors)


def test_the_finger_links_compose_as_the_finger_tracking_paper_says():
    # The finger-tracking paper, sec. 2.1: theta_i = phi_0 + ... + phi_i, R_i a turn by theta_i about x,
    # r_i = l_i (0, cos theta_i, sin theta_i), sensor k at sum_{i < i_k} r_i + alpha l_ik y_ik, and
    # its acceleration sum (w'_i x r_i - w_i^2 r_i) + w'_ik x h_k - w_ik^2 h_k.
    amp, freq = np.array([0.8, 0.6, 0.5]), np.array([2.0, 3.1, 4.3])
    motion = Motion(lambda t: quat.identity((len(t),)),
                    lambda t: amp * np.sin(np.outer(t, freq)))
    lengths, alpha = np.array([0.045, 0.025, 0.020]), 0.5
    t = np.linspace(0, 2, 41)
    truth = Simulator(finger_chain(tuple(lengths), alpha), motion).truth(t)

    phi = amp * np.sin(np.outer(t, freq))
    theta = np.cumsum(phi, axis=1)
    theta1 = np.cumsum(amp * freq * np.cos(np.outer(t, freq)), axis=1)
    theta2 = np.cumsum(-amp * freq**2 * np.sin(np.outer(t, freq)), axis=1)
    for i in range(3):
        expected = Rotation.from_rotvec(theta[:, i:i + 1] * [1, 0, 0])
        assert rot(truth.q_links[:, i + 1]).approx_equal(expected, atol=1e-12).all()

    def along(i):  # (0, cos theta_i, sin theta_i) and its perpendicular (0, -sin, cos)
        return np.stack([0 * t, np.cos(theta[:, i]), np.sin(theta[:, i])], -1), \
            np.stack([0 * t, -np.sin(theta[:, i]), np.cos(theta[:, i])], -1)

    for s, ik in enumerate((1, 2)):  # sensors on phalanges 1 and 2
        acc = np.zeros((len(t), 3))
        for i, length in [(i, lengths[i]) for i in range(ik)] + [(ik, alpha * lengths[ik])]:
            u, n = along(i)
            acc += length * (theta2[:, i:i + 1] * n - theta1[:, i:i + 1] ** 2 * u)
        f = Rotation.from_rotvec(theta[:, ik:ik + 1] * [1, 0, 0]).inv().apply(acc + [0, 0, G])
        assert truth.acc[:, s] == pytest.approx(f, abs=1e-6)


def test_the_grasp_motion_reaches_the_finger_tracking_papers_angles():
    move, delay = 1.5, 0.2
    truth = Simulator(finger_chain(), grasp(move, delay)).truth([0.0, delay, delay + move / 3,
                                                                 delay + move, 5.0])
    deg = np.degrees(truth.joints)
    expected = np.array([[0, 0, 0], [0, 0, 0], [-28, 0, 0], [90, 85, 85], [90, 85, 85]])
    assert deg == pytest.approx(expected, abs=1e-9)
    assert truth.gyr[[0, 4]] == pytest.approx(np.zeros((2, 2, 3)), abs=1e-9)  # still at both ends


def test_white_noise_has_the_data_sheet_density():
    errors = SensorErrors(gyr=ErrorModel(noise_density=GYR_NOISE_DENSITY),
                          acc=ErrorModel(noise_density=ACC_NOISE_DENSITY))
    for rate in (200.0, 1000.0):
        data = Simulator(arm_chain(), still((1, 0, 0, 0)), errors, seed=7).simulate(60.0, rate)
        for kind, density in (("gyr", GYR_NOISE_DENSITY), ("acc", ACC_NOISE_DENSITY)):
            e = (getattr(data, kind) - getattr(data.truth, kind))[:, 0]
            std = density * math.sqrt(rate)  # 0.035 deg/s at 200 Hz; 4.2 mg at 200 Hz
            assert e.std(axis=0) == pytest.approx([std] * 3, rel=0.03)
            assert np.abs(e.mean(axis=0)).max() < 5 * std / math.sqrt(len(e))
            lag1 = np.mean(e[1:] * e[:-1], axis=0) / e.var(axis=0)
            assert np.abs(lag1).max() < 0.03  # white


def test_the_data_sheet_offsets_are_constant_within_their_bounds_and_seeded():
    errors = mpu9250(noise=False, offset=True)
    sim = Simulator(arm_chain(), arm_swing(), errors, seed=11)
    data = sim.simulate(5.0, 100.0)
    lsb = errors.gyr.resolution
    e = data.gyr - data.truth.gyr
    assert np.abs(e - data.offset["gyr"]).max() <= lsb / 2 + 1e-12
    assert np.abs(data.offset["gyr"]).max() <= GYR_OFFSET_MAX
    assert np.abs(data.offset["acc"]).max() <= 60e-3 * 9.80665
    assert np.abs(data.offset["gyr"]).min() > 0.01 * GYR_OFFSET_MAX  # really drawn
    again = sim.simulate(5.0, 100.0)
    other = Simulator(arm_chain(), arm_swing(), errors, seed=12).simulate(5.0, 100.0)
    assert np.array_equal(again.gyr, data.gyr) and not np.array_equal(other.gyr, data.gyr)


def test_a_drifting_offset_is_a_random_walk_across_blocks():
    drift = 1e-3  # rad/s per sqrt(s)
    sim = Simulator(arm_chain(), still((1, 0, 0, 0)), SensorErrors(gyr=ErrorModel(drift=drift)),
                    seed=5)
    rate = 500.0
    e = sim.simulate(40.0, rate).gyr[:, 0]  # 20000 samples: several blocks of random numbers
    steps = np.diff(e, axis=0)
    assert steps.std(axis=0) == pytest.approx([drift / math.sqrt(rate)] * 3, rel=0.03)
    assert np.abs(steps[4095]).max() < 5 * drift / math.sqrt(rate)  # no jump between blocks


def test_scale_errors_are_constant_factors_within_the_tolerance():
    q0 = quat.from_euler([0.4, 0.9, -0.3], "ZYX")  # gravity on every axis
    data = Simulator(arm_chain(), still(q0), SensorErrors(acc=ErrorModel(scale_max=0.03)),
                     seed=2).simulate(1.0, 50.0)
    ratio = data.acc / data.truth.acc
    assert ratio == pytest.approx(np.broadcast_to(data.scale["acc"], ratio.shape), rel=1e-12)
    assert np.all(np.abs(data.scale["acc"] - 1) <= 0.03)


def test_quantisation_and_saturation():
    w = np.array([0.3, -0.8, 1.234])
    errors = SensorErrors(gyr=ErrorModel(resolution=0.01, full_scale=0.5))
    data = Simulator(arm_chain(), spin(w), errors).simulate(0.5, 100.0)
    assert data.gyr[:, 0] == pytest.approx(np.tile([0.3, -0.5, 0.5], (50, 1)), abs=1e-12)
    # The data sheet's 2000 deg/s full scale clips a 40 rad/s spin; 16-bit counts.
    data = Simulator(arm_chain(), spin([40.0, 1.0, 0.0]), mpu9250(noise=False, offset=False)) \
        .simulate(0.2, 100.0)
    lsb = math.radians(2000) / 32768
    assert data.gyr[:, 0, 0] == pytest.approx(math.radians(2000))
    assert data.gyr[:, 0, 1] == pytest.approx(round(1.0 / lsb) * lsb)


def test_the_flex_adc_follows_the_circuit_and_its_noise():
    for deg, adc in ((0.0, 391), (90.0, int(adc_from_degrees(90.0))), (FULL_BEND_DEG, 10)):
        data = Simulator(arm_chain(), still((1, 0, 0, 0), (math.radians(deg),))).simulate(0.1, 100.0)
        assert set(data.flex_adc.tolist()) == {adc}
    noise_v = 0.01  # volts at 100 Hz -> 2.05 counts
    errors = SensorErrors(flex=ErrorModel(noise_density=noise_v / math.sqrt(100.0)))
    data = Simulator(arm_chain(), still((1, 0, 0, 0), (1.0,)), errors, seed=9).simulate(100.0, 100.0)
    counts = noise_v / FlexCircuit().lsb_v
    assert data.flex_adc.std() == pytest.approx(math.sqrt(counts**2 + 1 / 12), rel=0.05)


def test_a_motion_with_the_wrong_number_of_joints_is_a_clear_error():
    with pytest.raises(ValueError, match="2 joint angles; the chain has 1 hinges"):
        Simulator(arm_chain(), still((1, 0, 0, 0), (0.1, 0.2))).truth([0.0])


def test_the_streaming_source_gives_the_batch_samples():
    sim = Simulator(arm_chain(), arm_swing(), mpu9250(), seed=4)
    data = sim.simulate(3.0, 200.0)
    source = SimulatedSource(sim, rate_hz=200.0)
    for k in list(range(0, 600, 7)) + [0, 599]:  # out of order and repeated, across blocks
        r = source.reading(k / 200.0)
        assert r.acc == tuple(data.acc[k, 0]) and r.gyr == tuple(data.gyr[k, 0])
        assert r.mag == tuple(data.mag[k, 0]) and r.flex_adc == data.flex_adc[k]
        assert r.q == tuple(data.truth.q_sensors[k, 0])


def test_blocks_of_a_stream_are_the_rows_of_the_batch():
    errors = SensorErrors(gyr=ErrorModel(noise_density=GYR_NOISE_DENSITY, offset_max=GYR_OFFSET_MAX,
                                         drift=1e-3, resolution=1e-4),
                          acc=ErrorModel(noise_density=ACC_NOISE_DENSITY, scale_max=0.03),
                          flex=ErrorModel(noise_density=1e-3, drift=1e-3))
    sim = Simulator(arm_chain(), arm_swing(), errors, seed=11)
    data = sim.simulate(25.0, 200.0)  # 5000 samples: more than one block of random numbers
    stream, edges = sim.stream(200.0), np.cumsum([0, 1, 7, 50, 333, 4096, 2, 511])
    blocks = [stream.block(int(k0), int(k1)) for k0, k1 in zip(edges[:-1], edges[1:])]
    for name in ("t", "gyr", "acc", "mag", "flex_adc"):
        assert np.array_equal(np.concatenate([getattr(b, name) for b in blocks]), getattr(data, name))
    for name in ("q_links", "joints", "q_sensors", "gyr", "acc", "mag", "flex_deg"):
        assert np.array_equal(np.concatenate([getattr(b.truth, name) for b in blocks]),
                              getattr(data.truth, name))
    later = stream.block(4000, 4100)  # again, out of order: the same samples
    assert np.array_equal(later.acc, data.acc[4000:4100]) and np.array_equal(later.gyr, data.gyr[4000:4100])
    assert all(np.array_equal(blocks[0].offset[k], data.offset[k]) for k in data.offset)
    assert all(np.array_equal(blocks[0].scale[k], data.scale[k]) for k in data.scale)
    assert len(stream.block(7, 7).t) == 0
    with pytest.raises(ValueError, match="0 <= k0 <= k1"):
        stream.block(5, 4)


def test_the_virtual_board_streams_simulated_motion_over_the_link():
    sim = Simulator(arm_chain(), arm_swing(), mpu9250(), seed=8)
    source = SimulatedSource(sim, rate_hz=200.0)
    settings = BoardSettings(rate_hz=200, stream_at_boot=False, keep_sent=1000)
    with VirtualBoard(motion=source, settings=settings) as board, \
            Link(LinkSettings(board.port)) as link:
        assert link.hello is not None and link.hello.mag_whoami == 0x48
        got = list(link.samples(1.0))
    assert len(got) >= 150
    sent = {wire(s) for s in board.sent}
    assert all(wire(s) in sent for s in got)
    for s in got:  # what arrived is the simulator's sample, quantised as the firmware does
        truth = quantise(source.reading(s.t_us / 1e6), s.t, s.t_us, s.seq, s.acc_fs_g, s.gyr_fs_dps)
        assert wire(s) == wire(truth)
    assert isinstance(got[0], P.RawSample)


def test_a_chain_works_out_its_hinges_and_arms_once():
    # Every block of samples reads them: they must not be built again at each use (as a cached_property
    # was in the compiled build). The arm by hand: the elbow 0.30 m down the upper arm, the IMU 0.30 m.
    chain = arm_chain(upper_arm_m=0.30, sensor_m=0.25)
    assert chain.hinges is chain.hinges and chain.arms[1] is chain.arms[1]  # (compiled, the tuple is boxed anew)
    assert chain.hinges.tolist() == [[0.0, 1.0, 0.0]]
    index, vectors = chain.arms
    assert index == [0, 0] and vectors.tolist() == [[0.0, 0.0, -0.30], [0.0, 0.0, -0.25]]
    assert chain == arm_chain(upper_arm_m=0.30, sensor_m=0.25) and "hinges" not in repr(chain)
