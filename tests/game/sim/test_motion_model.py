"""The simulated player: minimum-jerk moves, launch truth, idle safety, profiles, the simulator."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from game.body.avatar import Avatar
from game.body.pose import ArmPose
from game.sim.motion_model import (
    BOARD_RADIUS_M, DAMPING_RATIO, LAUNCH_THRESHOLD_DEG, MINIMUM_JERK_PEAK_ACC, SHARPEST_DEG_S2,
    STRAP_PIVOT_DEPTH_M, PlayerProfile, Script, direction, minimum_jerk, minimum_jerk_velocity, ring, session,
    tissue_response)
from tracker import quat as Q
from tracker import sim
from tracker.sim import Simulator, arm_chain, mpu9250

# A player without tremor or sway, the board glued to the bone: the moves alone.
STILL = PlayerProfile(tremor_deg=0.0, sway_deg=0.0, wobble_deg=0.0, twist_follow=1.0, slip_deg_per_min=0.0)


def angle_deg(a, b):
    return np.degrees(np.arccos(np.clip(np.sum(np.asarray(a) * np.asarray(b), axis=-1), -1, 1)))


# ------------------------------------------------------------ minimum jerk


def test_minimum_jerk_profile():
    assert minimum_jerk(0.0) == 0.0 and minimum_jerk(1.0) == 1.0
    assert minimum_jerk(-1.0) == 0.0 and minimum_jerk(2.0) == 1.0  # held outside
    assert minimum_jerk(0.5) == pytest.approx(0.5)
    assert minimum_jerk_velocity(0.0) == 0.0 and minimum_jerk_velocity(1.0) == 0.0
    tau = np.linspace(0, 1, 100001)
    v = minimum_jerk_velocity(tau)
    assert np.gradient(minimum_jerk(tau), tau)[1:-1] == pytest.approx(v[1:-1], abs=1e-6)
    mean = 1.0  # the distance 1 over the duration 1
    assert v.max() == pytest.approx(1.875 * mean) and tau[np.argmax(v)] == pytest.approx(0.5)
    h = 1e-4  # acceleration vanishes at both ends too
    assert abs(minimum_jerk(2 * h) - 2 * minimum_jerk(h)) / h**2 < 1e-2
    assert abs(minimum_jerk(1 - 2 * h) - 2 * minimum_jerk(1 - h) + 1) / h**2 < 1e-2


# ------------------------------------------------------------ launches


@pytest.fixture(scope="module")
def still_session():
    return session(STILL, seed=3, gestures=6, idle_s=(2.0, 4.0))


def test_launch_times_are_where_the_elbow_crosses_the_threshold(still_session):
    s = still_session
    assert len(s.launches) >= 6
    for launch in s.launches:
        assert s.flex_deg(launch.t_straight)[0] == pytest.approx(LAUNCH_THRESHOLD_DEG, abs=1e-6)
        before, after = s.flex_deg([launch.t_straight - 1e-3, launch.t_straight + 1e-3])
        assert before > LAUNCH_THRESHOLD_DEG > after
        assert s.flex_deg(launch.t_straight_start)[0] >= 90.0
        assert 0.04 < launch.t_straight - launch.t_straight_start < 0.25
        assert launch.charge_time > 0.5
    # every downward crossing inside a gesture is a recorded launch, and no other
    for seg in (x for x in s.segments if x.kind == "gesture"):
        t = np.arange(seg.t0, seg.t1, 1e-3)
        f = s.flex_deg(t) - LAUNCH_THRESHOLD_DEG
        crossings = t[1:][(f[:-1] >= 0) & (f[1:] < 0)]
        recorded = [x.t_straight for x in s.launches if seg.t0 <= x.t_straight <= seg.t1]
        assert crossings == pytest.approx(recorded, abs=1e-3)


def test_the_arm_points_at_the_recorded_target_during_the_launch(still_session):
    s = still_session
    for launch in s.launches:
        d = np.asarray(launch.direction_body)
        assert np.linalg.norm(d) == pytest.approx(1.0)
        t = np.linspace(launch.t_straight_start, launch.t_straight, 5)
        assert angle_deg(s.pointing(t), d).max() < 1.0
        elevation = math.degrees(math.acos(-d[2]))
        azimuth = math.degrees(math.atan2(d[0], d[1]))
        assert 60 <= elevation <= 120 and abs(azimuth) <= 60.0 + 1e-9


def test_given_targets_are_hit_and_azimuth_is_positive_to_the_right():
    script = Script(STILL, seed=5)
    launches = script.gesture(targets=[(30.0, 90.0), (-20.0, 100.0)])
    s = script.build()
    assert np.array([x.direction_body for x in launches]) == pytest.approx(
        np.array([direction(30.0, 90.0), direction(-20.0, 100.0)]))
    assert launches[0].direction_body[0] > 0 and launches[1].direction_body[0] < 0
    for launch in launches:
        assert angle_deg(s.pointing(launch.t_straight)[0], launch.direction_body) < 1e-6
    assert s.elevation_deg(s.duration_s)[0] == pytest.approx(0.0, abs=1e-9)  # back down


def test_tremor_stays_small_and_wobbles_the_aim():
    s = session(PlayerProfile(tremor_deg=0.5), seed=3, gestures=3, idle_s=1.0)
    for launch in s.launches:
        t = np.linspace(launch.t_straight_start, launch.t_straight, 20)
        err = angle_deg(s.pointing(t), launch.direction_body)
        assert err.max() < 1.5 and err.max() > 0.01


# ------------------------------------------------------------ idle


def test_idle_keeps_the_arm_down_whenever_the_elbow_bends():
    bent_seen, swing_seen = 0, 0.0
    for seed in range(4):
        s = session(PlayerProfile(), seed=seed, gestures=2, idle_s=(10.0, 14.0))
        for t0, t1 in s.idle_intervals:
            t = np.arange(t0, t1, 0.01)
            flex, elevation = s.flex_deg(t), s.elevation_deg(t)
            assert np.all(elevation[flex > 50] < 40)
            assert elevation.max() < 27.0 and flex.max() <= 60.0 + 1e-9
            bent_seen += int(np.sum(flex > 50))
            swing_seen = max(swing_seen, float(elevation.max()))
    assert bent_seen > 0 and swing_seen > 15  # the test saw bends and swings


def test_the_session_is_scripted_in_order():
    s = session(STILL, seed=2, gestures=3, idle_s=3.0)
    kinds = [x.kind for x in s.segments]
    assert kinds == ["calibration", "idle", "gesture", "idle", "gesture", "idle", "gesture", "idle"]
    ends = [(x.t0, x.t1) for x in s.segments]
    assert all(a[1] == pytest.approx(b[0]) for a, b in zip(ends, ends[1:]))
    assert s.duration_s == pytest.approx(ends[-1][1])
    assert s.idle_intervals == [(x.t0, x.t1) for x in s.segments if x.kind == "idle"]
    assert all(t1 - t0 == pytest.approx(3.0) for t0, t1 in s.idle_intervals)
    json.dumps(s.truth_json())


def test_calibration_poses_are_held_still_down_and_forward():
    s = session(STILL, seed=4, gestures=0, idle_s=0)
    down, forward = s.calibration
    assert down[1] - down[0] == pytest.approx(2.5, abs=0.2)
    assert forward[1] - forward[0] == pytest.approx(2.0, abs=0.25)
    assert s.pointing(np.linspace(*down, 20)) == pytest.approx(np.tile([0, 0, -1.0], (20, 1)))
    assert s.pointing(np.linspace(*forward, 20)) == pytest.approx(np.tile([0, 1.0, 0], (20, 1)), abs=1e-12)


def test_same_seed_same_session_other_seed_other_session():
    a, b, c = (session(PlayerProfile(), seed=k, gestures=2, idle_s=2.0) for k in (7, 7, 8))
    t = np.linspace(0, a.duration_s, 500)
    assert np.array_equal(a.motion.root(t), b.motion.root(t)) and a.launches == b.launches
    assert a.launches != c.launches


# ------------------------------------------------------------ speed


def test_speed_divides_every_movement_but_not_the_calibration_holds():
    slow = session(replace_speed(1.0), seed=9, gestures=3, idle_s=0, calibration=False)
    fast = session(replace_speed(2.0), seed=9, gestures=3, idle_s=0, calibration=False)
    assert fast.duration_s == pytest.approx(slow.duration_s / 2)
    assert len(fast.launches) == len(slow.launches)
    for a, b in zip(slow.launches, fast.launches):
        assert b.t_straight == pytest.approx(a.t_straight / 2)
        assert b.t_straight_start == pytest.approx(a.t_straight_start / 2)
        assert b.charge_time == pytest.approx(a.charge_time / 2)
        assert b.direction_body == pytest.approx(a.direction_body)
    t = np.linspace(0, slow.duration_s, 300)
    assert fast.motion.root(t / 2) == pytest.approx(slow.motion.root(t), abs=1e-9)
    # The game tells the player how long to hold the calibration poses: speed leaves them.
    slow_cal = session(replace_speed(1.0), seed=9, gestures=0, idle_s=0).calibration
    fast_cal = session(replace_speed(2.0), seed=9, gestures=0, idle_s=0).calibration
    for (a0, a1), (b0, b1) in zip(slow_cal, fast_cal):
        assert b1 - b0 == pytest.approx(a1 - a0)


def replace_speed(speed):
    return replace(STILL, speed=speed)


# ------------------------------------------------------------ profile


def test_profile_defaults_and_json(tmp_path):
    p = PlayerProfile()
    assert (p.upper_arm_m, p.forearm_m, p.mount_roll_deg, p.mount_pitch_deg) == (0.30, 0.27, 0.0, 0.0)
    assert (p.flex_straight_ohm, p.flex_bent_ohm, p.gyro_bias_dps) == (12000.0, 50000.0, 1.0)
    assert (p.noise_scale, p.speed) == (1.0, 1.0)
    # the board's figures are the simulator's typical board, the numbers kept in one place
    assert (p.gyro_bias_dps, p.gyro_warmup_dps) == (sim.TYPICAL_GYRO_BIAS_DPS, sim.TYPICAL_GYRO_WARMUP_DPS)
    assert (p.mag_hard_iron_ut, p.mag_soft_iron_pct, p.mag_disturbance_ut) == (
        sim.TYPICAL_MAG_HARD_IRON_UT, sim.TYPICAL_MAG_SOFT_IRON_PCT, sim.TYPICAL_MAG_DISTURBANCE_UT)
    assert (p.flex_hysteresis_pct, p.flex_creep_pct) == (sim.TYPICAL_FLEX_HYSTERESIS_PCT,
                                                         sim.TYPICAL_FLEX_CREEP_PCT)
    assert PlayerProfile.from_json({}) == p
    q = PlayerProfile.from_json({"speed": 2, "mount_roll_deg": -25.5})
    assert q.speed == 2.0 and isinstance(q.speed, float) and q.mount_roll_deg == -25.5
    assert PlayerProfile.from_json(q.to_json()) == q
    path = tmp_path / "player.json"
    path.write_text(json.dumps({"tremor_deg": 0.2}))
    assert PlayerProfile.load(path) == PlayerProfile(tremor_deg=0.2)


@pytest.mark.parametrize("data, key", [
    ({"sped": 2.0}, "sped"),
    ({"speed": "fast"}, "speed"),
    ({"speed": True}, "speed"),
    ({"speed": 0.0}, "speed"),
    ({"upper_arm_m": float("nan")}, "upper_arm_m"),
    ({"tremor_deg": float("inf")}, "tremor_deg"),
    ({"mount_pitch_deg": 200}, "mount_pitch_deg"),
    ({"gyro_bias_dps": None}, "gyro_bias_dps"),
    ({"flex_bent_ohm": 10000.0}, "flex_bent_ohm"),
])
def test_profile_rejects_bad_input_naming_the_key(data, key):
    with pytest.raises(ValueError, match=key) as e:
        PlayerProfile.from_json(data)
    assert "\n" not in str(e.value)


def test_profile_load_names_the_broken_file(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{not json")
    with pytest.raises(ValueError, match="broken.json"):
        PlayerProfile.load(path)
    path.write_text("[1, 2]")
    with pytest.raises(ValueError, match="JSON object"):
        PlayerProfile.load(path)


def test_profile_builds_the_worn_chain():
    p = PlayerProfile(upper_arm_m=0.32, mount_roll_deg=90.0, mount_pitch_deg=0.0)
    chain = p.chain()
    assert chain.links[0].length_m == 0.32 and chain.sensors[0].position_m == (0.0, 0.0, -0.32)
    assert Q.rotate(chain.sensors[0].mount, (1.0, 0, 0)) == pytest.approx([0, 1.0, 0])  # roll about z
    tilted = PlayerProfile(mount_pitch_deg=10.0).mount()
    assert Q.rotate(tilted, (0, 1.0, 0)) == pytest.approx([0, 1.0, 0])  # pitch about the hinge
    assert p.flex_sensor().bent_ohm == 50000.0
    assert p.sensor_errors() == sim.realistic_errors()  # the typical board
    q = PlayerProfile(gyro_bias_dps=3.0, noise_scale=2.0, gyro_warmup_dps=2.5, mag_hard_iron_ut=80.0,
                      mag_soft_iron_pct=12.0, mag_disturbance_ut=20.0, flex_hysteresis_pct=7.0,
                      flex_creep_pct=9.0)
    assert q.sensor_errors() == sim.realistic_errors(
        gyro_bias_dps=3.0, noise_scale=2.0, gyro_warmup_dps=2.5, mag_hard_iron_ut=80.0, mag_soft_iron_pct=12.0,
        mag_disturbance_ut=20.0, flex_hysteresis_pct=7.0, flex_creep_pct=9.0)


# ------------------------------------------------------------ in the simulator


def test_the_motion_runs_in_the_simulator_with_plausible_readings():
    profile = PlayerProfile()
    s = session(profile, seed=11, gestures=3, idle_s=(4.0, 6.0))
    data = Simulator(arm_chain(), s.motion, mpu9250(), seed=11).simulate(s.duration_s, 200.0)
    for x in (data.acc, data.gyr, data.mag, data.truth.acc, data.truth.gyr):
        assert np.all(np.isfinite(x))
    acc, gyr = np.linalg.norm(data.truth.acc[:, 0], axis=1), np.linalg.norm(data.truth.gyr[:, 0], axis=1)
    assert acc.max() < 40.0 and gyr.max() < 20.0
    assert gyr.max() > 2.0  # the arm really moves
    worn = Simulator(profile.chain(), s.motion, profile.sensor_errors(), profile.flex_sensor(), seed=1)
    assert np.all(np.isfinite(worn.simulate(10.0, 100.0).acc))


def test_sensor_frame_convention_in_the_calibration_poses():
    """Ideal wearing: hanging, the board feels +g on z; arm forward, +g on -x; raising turns about y."""
    s = session(STILL, seed=1, gestures=0, idle_s=0)
    sim = Simulator(arm_chain(), s.motion)
    (d0, d1), (f0, f1) = s.calibration
    down, forward = np.tile([0, 0, 9.81], (5, 1)), np.tile([-9.81, 0, 0], (5, 1))
    assert sim.truth(np.linspace(d0 + 0.01, d1 - 0.01, 5)).acc[:, 0] == pytest.approx(down, abs=1e-6)
    assert sim.truth(np.linspace(f0 + 0.01, f1 - 0.01, 5)).acc[:, 0] == pytest.approx(forward, abs=1e-6)
    gyr = sim.truth(np.linspace(d1, f0, 50)).gyr[:, 0]
    assert np.abs(gyr[:, [0, 2]]).max() < 1e-6 and gyr[:, 1].min() > -1e-9 and gyr[:, 1].max() > 1.0


def test_the_avatar_and_the_simulated_forearm_agree(still_session):
    """The root fed to the avatar (ideal mounting) points its arm and forearm where the sim's do."""
    s = still_session
    sim = Simulator(arm_chain(), s.motion)
    launch = s.launches[0]
    t = launch.t_straight_start - 0.05  # elbow bent at ~100 deg, the arm aimed
    truth = sim.truth([t])
    arm = Avatar().update(ArmPose(tuple(truth.q_links[0, 0]), float(truth.flex_deg[0]), t))
    assert arm.pointing == pytest.approx(launch.direction_body, abs=1e-9)
    forearm_sim = Q.rotate(truth.q_links[0, 1], (0, 0, -1.0))
    forearm_avatar = (arm.wrist - arm.elbow) / np.linalg.norm(arm.wrist - arm.elbow)
    assert forearm_avatar == pytest.approx(forearm_sim, abs=1e-9)
    assert forearm_sim[2] > 0.5  # a bent elbow with the arm level lifts the forearm


def test_a_built_session_does_not_change_when_the_script_goes_on():
    script = Script(STILL, seed=6)
    script.calibration()
    before = script.build()
    t = np.linspace(0, before.duration_s + 5.0, 200)
    q = before.motion.root(t)
    script.gesture()
    assert np.array_equal(before.motion.root(t), q) and before.launches == []
    assert script.build().launches


def test_a_stream_of_a_script_that_goes_on_keeps_the_samples_already_taken():
    profile = PlayerProfile()
    script = Script(profile, seed=2)
    script.idle(3.0)
    live = script.motion
    t = np.linspace(0.0, 3.0, 101)
    root, joints = live.at(t)
    assert np.array_equal(root, script.root(t)) and np.array_equal(joints, script.joints(t))
    stream = Simulator(profile.chain(), live, profile.sensor_errors(), profile.flex_sensor(), seed=2) \
        .stream(200.0)
    first = stream.block(0, 500)  # up to 2.5 s, before the script's end
    script.gesture()
    whole = Simulator(profile.chain(), script.build().motion, profile.sensor_errors(), profile.flex_sensor(),
                      seed=2).simulate(script.now, 200.0)
    for name in ("gyr", "acc", "mag", "flex_adc"):
        assert np.array_equal(getattr(first, name), getattr(whole, name)[:500])
    assert np.array_equal(stream.block(500, 900).acc, whole.acc[500:900])  # the gesture, as scripted later


def test_forgetting_the_past_leaves_the_motion_from_then_on_unchanged():
    script = Script(PlayerProfile(), seed=4)
    for _ in range(3):
        script.idle(5.0)
        script.gesture()
    t = np.linspace(12.0, script.now + 1.0, 777)
    before = script.pose(t)
    waves = len(script._waves)
    script.forget_before(12.0)
    after = script.pose(t)
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])
    assert len(script._waves) < waves
    script.gesture()  # and it can go on


# ------------------------------------------------------------ the player and the strap


def spectrum(x, rate):
    """One-sided amplitude spectrum of ``x`` (a sine of amplitude a at a bin shows a)."""
    return np.fft.rfftfreq(len(x), 1 / rate), 2 * np.abs(np.fft.rfft(x)) / len(x)


def test_a_tremor_of_a_degrees_at_f_hz_turns_the_arm_at_2_pi_f_a():
    """Worked by hand: sx = A sin(2 pi f t) is a rate about the hinge of 2 pi f A cos(2 pi f t)."""
    a_deg, f_hz, rate, seconds = 0.5, 6.0, 200.0, 100.0
    profile = replace(STILL, tremor_deg=a_deg, tremor_hz=f_hz)
    script = Script(profile, seed=3)
    truth = Simulator(profile.chain(), script.motion).truth(np.arange(0, seconds, 1 / rate))
    sx = script.channels(truth.t)["sx"]
    assert np.abs(sx).max() <= a_deg + 1e-12 and np.abs(sx).max() > 0.8 * a_deg  # peak tremor_deg
    hinge = np.degrees(truth.gyr[:, 0, 1])  # the bone's x (sx) is the board's y, the hinge
    freq, rate_amp = spectrum(hinge, rate)
    _, angle_amp = spectrum(sx, rate)
    for k in np.argsort(angle_amp)[-4:]:  # the tremor's components, each 2 pi f times its angle
        assert abs(freq[k] - f_hz) <= 1.0 + 1e-9
        assert rate_amp[k] == pytest.approx(2 * np.pi * freq[k] * angle_amp[k], rel=0.02)
    assert 0.8 * 2 * np.pi * (f_hz - 1) * a_deg < np.abs(hinge).max() < 2 * np.pi * (f_hz + 1) * a_deg


def test_sway_stays_within_sway_deg_and_is_slow():
    profile = replace(STILL, sway_deg=3.0)
    s = Script(profile, seed=5)
    t = np.arange(0, 300, 0.05)
    c = s.channels(t)
    sway = np.hypot(c["sx"], c["sy"])
    assert sway.max() <= 3.0 + 1e-12 and sway.max() > 1.5
    session_ = s.build()
    assert session_.elevation_deg(t).max() <= 3.0 + 1e-9  # the hanging arm points within it
    for channel in ("sx", "sy"):
        freq, amp = spectrum(c[channel], 20.0)
        power = amp**2
        assert power[(freq >= 0.09) & (freq <= 1.01)].sum() > 0.99 * power.sum()


def test_the_ring_decays_with_the_damping_ratio_at_the_damped_frequency():
    x = np.linspace(0, 12 * np.pi, 200001)
    r = ring(x)
    assert r.max() == pytest.approx(1.0) and r[0] == 0.0
    assert np.gradient(r, x)[0] == pytest.approx(0.0, abs=1e-3)  # no jump of the rate at the kick
    peaks = x[1:-1][(r[1:-1] > r[:-2]) & (r[1:-1] > r[2:]) & (x[1:-1] > np.pi)]
    assert np.diff(peaks) == pytest.approx(2 * np.pi, rel=1e-3)  # one damped period apart
    zeta = DAMPING_RATIO
    decrement = np.log(ring(peaks[:-1]) / ring(peaks[1:]))
    assert decrement == pytest.approx(2 * np.pi * zeta / math.sqrt(1 - zeta**2), rel=1e-3)


def test_a_fast_move_rocks_the_board_at_wobble_hz_scaled_by_its_sharpness():
    profile = replace(STILL, wobble_deg=4.0, wobble_hz=20.0, speed=4.0)
    script = Script(profile, seed=2)
    t0 = script.now
    t1 = script.reach(0.0, 90.0)  # a raise about the hinge: the board rocks about link y
    t = np.linspace(t1, t1 + 0.5, 50001)
    ry = script.channels(t)["ry"]
    sharpness = MINIMUM_JERK_PEAK_ACC * 90.0 / (t1 - t0) ** 2 / SHARPEST_DEG_S2
    assert 0.05 < sharpness < 1 and ry.max() == pytest.approx(4.0 * sharpness, rel=1e-3)  # overshoots
    peaks = t[1:-1][(ry[1:-1] > ry[:-2]) & (ry[1:-1] > ry[2:])]
    f_d = 20.0 * math.sqrt(1 - DAMPING_RATIO**2)
    assert np.diff(peaks[:3]) == pytest.approx(1 / f_d, rel=1e-3)
    assert np.abs(script.channels(t1 + 2.0)["ry"]) < 1e-9  # over
    # the bone is not rocked: the truth is where the arm went
    assert script.build().pointing(t) == pytest.approx(np.tile(direction(0.0, 90.0), (len(t), 1)), abs=1e-12)


def relative_rotvec(script, t):
    """The board relative to the bone in the simulator (the upper-arm link), as a rotation
    vector in degrees (N, 3)."""
    truth = Simulator(arm_chain(), script.motion).truth(t)
    rel = Q.multiply(Q.conjugate(truth.q_links[:, 0]), truth.q_sensors[:, 0])
    return np.degrees(Q.to_rotvec(rel))


def test_the_board_follows_twist_follow_of_the_bones_twist():
    profile = replace(STILL, twist_follow=0.6)
    script = Script(profile, seed=8)
    script.gesture(targets=[(20.0, 95.0)])
    t = np.linspace(0, script.now, 3000)
    twist = script.channels(t)["tw"]
    assert np.abs(twist).max() > 2.0  # the gesture twists the arm
    rel = relative_rotvec(script, t)
    assert rel[:, :2] == pytest.approx(0.0, abs=1e-9)
    assert rel[:, 2] == pytest.approx(-(1 - 0.6) * twist, abs=1e-9)  # so the board turns 0.6 of it


def test_the_board_slips_round_the_arm_at_slip_deg_per_min():
    for seed in (1, 2, 3):
        script = Script(replace(STILL, slip_deg_per_min=3.0), seed=seed)
        rel = relative_rotvec(script, np.array([0.0, 60.0, 120.0]))
        assert np.abs(rel[:, 2]) == pytest.approx([0.0, 3.0, 6.0], abs=1e-9)


def test_at_rest_the_tremor_rolls_the_board_about_the_arm_within_wobble_deg():
    """The board's roll at rest follows the tissue's response (hand: at resonance r = 1, the
    gain is 1 / (2 zeta)), never beyond wobble_deg."""
    gain, lag = tissue_response(1.0)
    assert gain == pytest.approx(1 / (2 * DAMPING_RATIO)) and lag == pytest.approx(np.pi / 2)
    assert tissue_response(0.0)[0] == 0.0 and tissue_response(100.0)[0] == pytest.approx(1.0, abs=1e-3)
    t = np.arange(0, 60, 0.002)
    calm = Script(replace(STILL, tremor_deg=0.02, tremor_hz=9.0, wobble_deg=2.0, wobble_hz=9.0), seed=1)
    roll = calm.channels(t)["rz"]
    lever = calm.profile.upper_arm_m / BOARD_RADIUS_M
    assert 0.3 * lever * 0.02 < np.abs(roll).max() <= gain * lever * 0.02 * 1.001
    shaky = Script(replace(STILL, tremor_deg=1.0, tremor_hz=5.0, wobble_deg=0.8), seed=1)
    assert np.abs(shaky.channels(t)["rz"]).max() <= 0.8 + 1e-12


def test_launch_truth_is_where_the_bone_pointed_not_the_board():
    s = session(replace(PlayerProfile(), wobble_deg=4.0), seed=3, gestures=4, idle_s=1.0)
    board_off = []
    for launch in s.launches:
        bone = s.pointing(launch.t_straight)[0]
        assert bone == pytest.approx(launch.direction_body, abs=1e-12)
        q_board = Simulator(arm_chain(), s.motion).truth([launch.t_straight]).q_sensors[0, 0]
        board_off.append(angle_deg(Q.rotate(q_board, (0.0, 0.0, -1.0)), bone))
    assert max(board_off) > 0.05  # the board rocks off the bone at the snap


def test_the_strap_rocks_the_board_on_the_arm_not_the_arm():
    """A snappy reach rocks the board (at 20 Hz, up to 4 deg) about a point in the soft tissue
    STRAP_PIVOT_DEPTH_M under it: its rate gains the rocking's, its acceleration at most about
    (2 pi f)^2 A STRAP_PIVOT_DEPTH_M (not the upper arm's 0.3 m times it); the arm itself, the
    elbow's hinge and the forearm, follow the bone alone."""
    profile = replace(STILL, wobble_deg=4.0, wobble_hz=20.0, speed=4.0)
    script = Script(profile, seed=2)
    script.reach(40.0, 90.0)  # kicks both the hinge (raise) and link x (the swing across)
    t = np.arange(0.0, script.now + 1.0, 1 / 1000)
    chain = arm_chain(upper_arm_m=profile.upper_arm_m, sensor_m=profile.upper_arm_m)
    worn = Simulator(chain, script.motion).truth(t)
    bare = Simulator(chain, replace(script.motion, mount=None)).truth(t)
    assert np.array_equal(worn.q_links, bare.q_links)  # the bone and the forearm do not rock
    c = script.channels(t)
    strap = np.stack([c["rx"], c["ry"], c["rz"]], axis=-1)
    assert np.abs(c["ry"]).max() > 0.5 and np.abs(c["rx"]).max() > 0.2  # rocked about both
    rel = Q.multiply(Q.conjugate(worn.q_links[:, 0]), worn.q_sensors[:, 0])
    assert np.degrees(Q.to_rotvec(rel)) == pytest.approx(strap, abs=1e-9)
    # the rate it adds: 2 pi f A at most
    extra_rate = np.degrees(np.linalg.norm(worn.gyr[:, 0] - Q.rotate(Q.conjugate(rel), bare.gyr[:, 0]), axis=1))
    w, a = 2 * np.pi * 20.0, math.radians(np.abs(strap).max())
    assert 0.3 * math.degrees(w * a) < extra_rate.max() < 1.5 * math.degrees(w * a)
    # the acceleration it adds: of order w^2 A r, r = STRAP_PIVOT_DEPTH_M
    def world(truth):
        return Q.rotate(truth.q_sensors[:, 0], truth.acc[:, 0])
    extra_acc = np.linalg.norm(world(worn) - world(bare), axis=1).max()
    assert 0.1 * w**2 * a * STRAP_PIVOT_DEPTH_M < extra_acc < 2.0 * w**2 * a * STRAP_PIVOT_DEPTH_M
    assert extra_acc < w**2 * a * profile.upper_arm_m / 3


def test_the_shoulder_rises_with_the_arm_and_bounces_while_walking():
    """The chain hangs from a shoulder that moves (Script, "Shoulder"): the board stays its
    0.3 m from it (within what the strap rocks it); still outside idle stretches with the arm
    down, raised 2 cm (half of the 4 cm overhead) with the arm level; walking bounces it by 2-5 cm
    from top to bottom."""
    profile = PlayerProfile()
    script = session(profile, seed=2, gestures=6, idle_s=(20.0, 30.0))
    t = np.arange(0.0, script.duration_s, 0.01)
    truth = profile.simulator(script.motion, 2).truth(t)
    s = script.motion.shoulder(t, truth.q_links[:, 0])
    assert np.allclose(np.linalg.norm(truth.p_sensors[:, 0] - s, axis=1), 0.30, atol=0.003)  # the strap rocks it
    elevation = script.elevation_deg(t)
    idle = np.zeros(len(t), dtype=bool)
    for t0, t1 in script.idle_intervals:
        idle |= (t >= t0) & (t <= t1)
    assert np.all(np.abs(s[~idle & (elevation < 5.0)]) < 0.001)
    level = ~idle & (np.abs(elevation - 90.0) < 3.0)
    assert level.any() and np.allclose(s[level, 2], 0.02, atol=0.0015)
    bounce = max(np.ptp(s[(t >= t0) & (t <= t1), 2]) for t0, t1 in script.idle_intervals)
    assert 0.02 <= bounce <= 0.05 + 0.001
