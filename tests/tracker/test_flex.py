"""The flex sensor against the circuit worked by hand (Zhu & Shi, sec. 4) and known responses."""

import json
import math

import numpy as np
import pytest

from tracker import atomic
from tracker.flex import (FULL_BEND_DEG, FlexCalibration, FlexCalibrationError, FlexCircuit,
                          FlexParams, FlexSensor, FlexStatus, FlexTracker, adc_from_degrees,
                          degrees_from_adc)

# By hand: I = (5.0 - 2.5) / 51k = 49.02 uA; 12k -> 2.5 - 0.5882 = 1.9118 V; 50k -> 0.0490 V.
# ADC = floor(V * 1024 / 5): 1.9118 V * 204.8 = 391.5 -> 391; 0.0490 V * 204.8 = 10.04 -> 10.
I_HAND = 2.5 / 51e3
DEG_PER_LSB = (5 / 1024) / I_HAND / ((50e3 - 12e3) / FULL_BEND_DEG)  # 0.333 degree


def test_circuit_worked_by_hand():
    c = FlexCircuit()
    assert c.current_a == pytest.approx(49.0196e-6, rel=1e-5)
    assert c.volts([12e3, 50e3]) == pytest.approx([1.911765, 0.049020], abs=1e-6)
    assert adc_from_degrees([0.0, FULL_BEND_DEG]).tolist() == [391, 10]
    assert c.adc(c.volts([0.0, 1e9])).tolist() == [512, 0]  # shorted sensor: Vref; open: the 0 V rail
    assert c.volts_at(391) == pytest.approx(391.5 * 5 / 1024)
    assert c.ohms(c.volts_at(391)) == pytest.approx((2.5 - 391.5 * 5 / 1024) / I_HAND)


def test_eq1_goes_below_the_rail_above_rf_and_is_clipped():
    c = FlexCircuit()
    assert c.volts(51e3) == pytest.approx(0.0, abs=1e-12)
    assert c.volts(80e3) == 0.0 and c.adc(c.volts(80e3)) == 0


def test_degrees_adc_round_trip_is_within_half_a_count():
    deg = np.linspace(0.0, FULL_BEND_DEG, 1001)
    back = degrees_from_adc(adc_from_degrees(deg))
    assert np.max(np.abs(back - deg)) <= DEG_PER_LSB / 2 + 1e-9
    ohms = np.linspace(12e3, 50e3, 11)
    assert FlexCircuit().ohms(FlexCircuit().volts(ohms)) == pytest.approx(ohms)
    assert FlexSensor().degrees(FlexSensor().ohms(deg)) == pytest.approx(deg)


def test_paper_preset_is_eq3_on_its_0_to_90_degree_range():
    adc = np.arange(100, 420)
    paper = FlexCalibration.paper().degrees(adc)
    assert paper == pytest.approx(np.clip(-(adc - 390) / 3, 0, 90))


def test_the_default_model_agrees_with_the_paper_map_within_half_a_degree():
    adc = np.arange(120, 391)
    model = FlexCalibration.from_model()
    assert np.max(np.abs(model.degrees(adc) - (-(adc - 390) / 3))) < 0.5
    # ... and the calibration of the model is the circuit chain itself, on the range.
    assert model.degrees(adc) == pytest.approx(degrees_from_adc(adc), abs=1e-9)


@pytest.mark.parametrize("cal", [FlexCalibration.from_model(), FlexCalibration(100.0, 900.0, 120.0, 0.4)])
def test_one_count_gives_what_the_array_map_gives(cal):
    adc = np.arange(-5, 1030)  # beyond both ends of the range too
    one = [cal.degrees_one(int(a)) for a in adc]
    assert all(type(d) is float for d in one)
    assert one == cal.degrees(adc).tolist()


def test_two_poses_recover_a_linear_response():
    rng = np.random.default_rng(1)
    true_adc = lambda deg: 405.0 - 2.4 * deg  # a person whose sensor is stiffer than the paper's
    straight = np.round(true_adc(0) + rng.normal(0, 0.7, 400))
    bent = np.round(true_adc(120) + rng.normal(0, 0.7, 400))
    cal = FlexCalibration.from_poses(straight, bent, bent_deg=120)
    deg = np.linspace(0, 120, 25)
    assert cal.curve == 0.0
    assert cal.degrees(true_adc(deg)) == pytest.approx(deg, abs=0.2)


def quadratic(adc):
    """A known monotonic response: 0 degrees at 380 counts, 135 at 80."""
    x = 380.0 - np.asarray(adc, dtype=float)
    return 0.3 * x + 0.0005 * x**2


def test_a_middle_pose_recovers_a_quadratic_response_exactly():
    a90 = 380 - (-0.3 + math.sqrt(0.09 + 4 * 0.0005 * 90)) / (2 * 0.0005)  # solves quadratic = 90
    cal = FlexCalibration.from_poses([380.0] * 5, [80.0] * 5, bent_deg=135.0,
                                     middle=[([a90] * 5, 90.0)])
    adc = np.linspace(80, 380, 61)
    assert cal.degrees(adc) == pytest.approx(quadratic(adc), abs=1e-9)


def test_several_middle_poses_fit_the_quadratic_by_least_squares():
    middle = [([a], float(quadratic(a))) for a in (300.0, 200.0, 120.0)]
    cal = FlexCalibration.from_poses([380.0], [80.0], bent_deg=135.0, middle=middle)
    adc = np.linspace(80, 380, 61)
    assert cal.degrees(adc) == pytest.approx(quadratic(adc), abs=1e-9)


@pytest.mark.parametrize("straight, bent, middle, message", [
    ([300, 301], [295, 296], (), "almost the same"),
    ([0, 0], [200, 201], (), "rail"),
    ([390], [1023], (), "rail"),
    ([], [100], (), "no usable samples"),
    ([390], [100], [([380], 90.0)], "backwards"),
    ([390], [100], [([200], 150.0)], "between 0 and"),
])
def test_bad_poses_are_clear_errors(straight, bent, middle, message):
    with pytest.raises(FlexCalibrationError, match=message):
        FlexCalibration.from_poses(straight, bent, bent_deg=127.0, middle=middle)


def test_calibration_saves_and_loads(tmp_path):
    path = tmp_path / "alice.flex.json"
    cal = FlexCalibration(388.5, 40.25, 130.0, -0.125)
    cal.save(path)
    assert FlexCalibration.load(path) == cal
    assert json.loads(path.read_text())["kind"] == "energyball.flex_calibration"
    assert [p.name for p in tmp_path.iterdir()] == ["alice.flex.json"]  # no temporary left


def test_a_failed_save_leaves_the_old_calibration_whole(tmp_path, monkeypatch):
    path = tmp_path / "bob.flex.json"
    old = FlexCalibration(390.0, 20.0)
    old.save(path)

    def crash(*args):
        raise OSError("disk pulled")

    monkeypatch.setattr(atomic.os, "replace", crash)
    with pytest.raises(OSError):
        FlexCalibration(350.0, 30.0).save(path)
    assert FlexCalibration.load(path) == old
    assert [p.name for p in tmp_path.iterdir()] == ["bob.flex.json"]  # the temporary is gone


@pytest.mark.parametrize("content, message", [
    ("", "bad JSON"),
    ('{"kind": "energyball.flex_calibration", "version": 1, "adc_str', "bad JSON"),
    (b"\xff\xfe\x00", "bad JSON"),
    ("[1, 2]", "not a flex calibration"),
    ('{"kind": "something else"}', "not a flex calibration"),
    ('{"kind": "energyball.flex_calibration", "version": 9}', "version 9"),
    ('{"kind": "energyball.flex_calibration", "version": 1, "adc_straight": 390}', "missing adc_bent"),
    ('{"kind": "energyball.flex_calibration", "version": 1, "adc_straight": "390", '
     '"adc_bent": 10, "bent_deg": 127, "curve": 0}', "finite number"),
    ('{"kind": "energyball.flex_calibration", "version": 1, "adc_straight": NaN, '
     '"adc_bent": 10, "bent_deg": 127, "curve": 0}', "finite number"),
    ('{"kind": "energyball.flex_calibration", "version": 1, "adc_straight": true, '
     '"adc_bent": 10, "bent_deg": 127, "curve": 0}', "numbers"),
    ('{"kind": "energyball.flex_calibration", "version": 1, "adc_straight": 390, '
     '"adc_bent": 10, "bent_deg": 127, "curve": 3}', "backwards"),
    ('{"kind": "energyball.flex_calibration", "version": 1, "adc_straight": 390, '
     '"adc_bent": 390, "bent_deg": 127, "curve": 0}', "read the same count"),
])
def test_a_broken_calibration_file_is_a_clear_error_naming_it(tmp_path, content, message):
    path = tmp_path / "broken.json"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(FlexCalibrationError, match=message) as e:
        FlexCalibration.load(path)
    assert str(path) in str(e.value) and isinstance(e.value, ValueError)


def test_a_missing_calibration_file_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError):
        FlexCalibration.load(tmp_path / "nobody.json")


# ------------------------------------------------------------------ streaming

RATE = 200.0


def ramp_tracker() -> FlexTracker:
    """Three counts a degree, like the paper, over a range long enough to settle a ramp."""
    return FlexTracker(FlexCalibration(adc_straight=1000.0, adc_bent=10.0, bent_deg=330.0))


def test_smoothing_lag_on_a_ramp_is_one_over_two_pi_fc():
    tracker, p = ramp_tracker(), FlexParams()
    speed = 200.0  # deg/s: 3 counts a sample at 200 Hz, exact on the ADC grid
    n = 300
    out = [tracker.update(1000 - 3 * k, k / RATE) for k in range(n)]
    assert all(r.status is FlexStatus.OK for r in out)
    lag_s = (out[-1].raw_deg - out[-1].deg) / speed
    # Casiez et al.'s speed, raw less the previous smoothed value, is v (1 + tau / dt) on a settled ramp;
    # with fc = min_cutoff + beta * that speed, tau = 1 / (2 pi fc) is the positive root of
    # (2 pi beta v / dt) tau^2 + 2 pi (min_cutoff + beta v) tau - 1 = 0
    a = 2 * math.pi * p.beta * speed * RATE
    b = 2 * math.pi * (p.min_cutoff_hz + p.beta * speed)
    tau = (-b + math.sqrt(b * b + 4 * a)) / (2 * a)
    assert lag_s == pytest.approx(tau, rel=0.01)
    fc = p.min_cutoff_hz + p.beta * speed * (1 + tau * RATE)
    assert lag_s == pytest.approx(1 / (2 * math.pi * fc), rel=0.01)
    assert lag_s < 0.007  # half the 13.8 ms of a speed differenced between raw angles


def test_smoothing_steadies_a_still_arm_and_follows_a_step_quickly():
    tracker = ramp_tracker()
    still = [tracker.update(700 + (k % 2), k / RATE).deg for k in range(400)]
    assert np.ptp(still[200:]) < 0.1 * (1 / 3)  # a count of jitter is a third of a degree
    step = [tracker.update(400, 2.0 + k / RATE).deg for k in range(1, 41)]
    assert step[-1] == pytest.approx((1000 - 400) / 3, abs=1.0)  # within 0.2 s


def test_a_rail_is_reported_and_the_last_angle_held():
    tracker = FlexTracker(FlexCalibration.paper())
    for k in range(20):
        good = tracker.update(240, k / RATE)
    assert good.status is FlexStatus.OK and good.deg == pytest.approx(50.0)
    for adc in (0, 1, 1023, 1022):
        r = tracker.update(adc, 1.0)
        assert r.status is FlexStatus.RAIL and r.deg == pytest.approx(50.0)
    assert tracker.state.calibration == FlexCalibration.paper()  # a rail never moves the range
    assert tracker.update(240, 1.1).status is FlexStatus.OK


def test_an_unchanging_adc_is_reported_stuck_and_recovers():
    tracker, p = FlexTracker(), FlexParams()
    t = np.arange(0, p.stuck_after_s + 1, 1 / RATE)
    status = [tracker.update(300, x).status for x in t]
    stuck_from = t[status.index(FlexStatus.STUCK)]
    assert stuck_from == pytest.approx(p.stuck_after_s, abs=1 / RATE)
    assert tracker.update(301, t[-1] + 0.005).status is FlexStatus.OK


def test_the_range_follows_a_player_beyond_it_but_not_a_spike():
    tracker = FlexTracker(FlexCalibration.paper())  # straight at 390
    tracker.update(390, 0.0)
    spike = tracker.update(420, 1 / RATE)
    assert spike.deg == 0.0
    assert tracker.state.calibration.adc_straight == pytest.approx(390 + 30 * (1 - math.exp(-0.005)))
    for k in range(2, int(6 * RATE)):  # six range time constants reading 400: straighter than 390
        r = tracker.update(400, k / RATE)
    assert tracker.state.calibration.adc_straight == pytest.approx(400, abs=0.03)
    assert r.deg == pytest.approx(0.0, abs=0.01)
    for k in range(int(6 * RATE)):  # and a deeper bend than the paper's 90 degrees
        r = tracker.update(60, 6 + k / RATE)
    cal = tracker.state.calibration
    assert cal.adc_bent == pytest.approx(60, abs=0.2) and r.deg == pytest.approx(90, abs=0.1)
    u = (230 - cal.adc_straight) / (cal.adc_bent - cal.adc_straight)
    assert tracker.update(230, 12.1).raw_deg == pytest.approx(90 * u)


def test_time_running_backwards_does_not_break_the_tracker():
    tracker = FlexTracker()
    tracker.update(300, 10.0)
    r = tracker.update(250, 5.0)  # the board reset its clock
    assert math.isfinite(r.deg) and r.status is FlexStatus.OK
    assert tracker.state.calibration == FlexCalibration.from_model()
    later = [tracker.update(250, 5.0 + k / RATE).deg for k in range(1, 200)]
    assert later[-1] == pytest.approx(float(FlexCalibration.from_model().degrees(250)), abs=0.01)
