"""The papers' simulation findings, stated as checks on reduced, seeded grids.

The IMU and infrared hand-tracking paper, sec. 4.1 (static drift): without the
correction a static IMU's orientation drifts at the rate of its gyroscope bias;
with it the error stays bounded. Inertial Sensor Based Solution for Finger Motion Tracking
(Computers 9(2):40, 2020), sec. 3 (Figure 10): with sensor offsets, integration beats
gravity alone for short motions and loses for long ones, crossing over on the
order of a second; the switching and hinge filters follow the better of the
two; white noise hurts the switching filter more than the Madgwick-type one.
"""

import json
import math
import sys

import numpy as np
import pytest

from tracker import quat as Q
from tracker import sim
from tracker.experiments import (ALGORITHMS, SERIES, finger_grasp, flexion_angle, gravity_angle,
                                 integrated_angle, plot_finger_grasp, plot_static_drift,
                                 rms_error_deg, static_drift)

from ..unavailable import unavailable

MINUTES = 1.0
BIASES_DPS = (0.05, 0.1, 0.2)
DURATIONS = (0.1, 0.3, 1.0, 3.0, 10.0, 100.0)
# The finger-tracking paper: both filters are "only limited by the errors of the accelerometer". A zero-g
# offset of up to 60 mg on each of the two in-plane axes tilts a gravity reading by up to
# atan(sqrt(2) * 0.06) = 4.9 degrees.
ACC_LIMIT_DEG = math.degrees(math.atan(math.sqrt(2) * sim.ACC_OFFSET_MAX / sim.STANDARD_GRAVITY))
# The distal sensor of a grasp lasting t_m peaks at 1.875 * 288 deg / (2 t_m / 3) = 810 / t_m deg/s
# (minimum-jerk profile); the switching filter treats 2000 deg/s (the MPU-9250's full scale) as
# saturated and takes gravity, so it is judged from 0.5 s on.
SWITCHING_FROM_S = 0.5


@pytest.fixture(scope="module")
def drift() -> tuple[dict, list[str]]:
    messages: list[str] = []
    return static_drift(minutes=MINUTES, biases_dps=BIASES_DPS, seed=0, progress=messages.append), messages


@pytest.fixture(scope="module")
def grasp() -> tuple[dict, list[str]]:
    messages: list[str] = []
    return finger_grasp(DURATIONS, seed=0, progress=messages.append), messages


def curves(result: dict, series: str) -> dict[str, np.ndarray]:
    return {a: np.array(v) for a, v in result["series"][series].items()}


# ---------------------------------------------------------------- building blocks


def test_gravity_angle_inverts_the_specific_force_at_rest():
    """The finger-tracking paper, sec. 2.2.2, in our axes: at rest a link at theta reads (0, g sin theta,
    g cos theta)."""
    theta = np.radians([-170.0, -28.0, 0.0, 45.0, 90.0, 175.0])
    acc = 9.81 * np.stack([np.zeros_like(theta), np.sin(theta), np.cos(theta)], axis=-1)
    np.testing.assert_allclose(gravity_angle(acc), theta, atol=1e-12)


def test_flexion_angle_is_the_hinge_angle_and_ignores_heading():
    theta = np.radians([-100.0, -28.0, 0.0, 60.0, 175.0])
    q = Q.from_axis_angle([1.0, 0.0, 0.0], theta)
    np.testing.assert_allclose(flexion_angle(q), theta, atol=1e-12)
    turned = Q.multiply(Q.from_axis_angle([0.0, 0.0, 1.0], 2.0), q)  # a heading error only
    np.testing.assert_allclose(flexion_angle(turned), theta, atol=1e-12)


def test_integration_of_a_constant_rate_is_exact():
    rate, omega = 200.0, np.full((401, 2), 0.5)
    theta = integrated_angle(omega, np.array([0.1, -0.2]), rate)
    np.testing.assert_allclose(theta[-1], [0.1 + 0.5 * 2.0, -0.2 + 0.5 * 2.0], atol=1e-12)
    np.testing.assert_allclose(theta[0], [0.1, -0.2])


def test_rms_error_wraps_to_the_shorter_way_round():
    assert rms_error_deg(np.radians([350.0, -5.0]), np.zeros(2)) == pytest.approx(math.sqrt(62.5))


# ---------------------------------------------------- the hand-tracking paper, sec. 4.1


def test_static_drift_shape_progress_and_json(drift):
    result, messages = drift
    assert result["minutes"] == pytest.approx(MINUTES)
    assert [m["bias_dps"] for m in result["imus"]] == list(BIASES_DPS)
    assert len(messages) == len(BIASES_DPS)
    assert json.loads(json.dumps(result)) == result


def test_without_correction_the_error_is_the_integrated_bias(drift):
    """Correction off: bias b deg/s on each axis turns a still IMU by phi = sqrt(3) b T about
    (1, 1, 1)/sqrt(3). Checked: the total error is phi, and the inclination (heading-free)
    error is acos(cos phi + (1 - cos phi)/3), the tilt of z under that turn, each within
    1 degree (the start levelled from one noisy sample, white-noise random walk and
    quantisation); and the error grows with the bias."""
    result, _ = drift
    seconds = MINUTES * 60.0
    for imu in result["imus"]:
        phi = math.radians(math.sqrt(3) * imu["bias_dps"] * seconds)
        tilt = math.degrees(math.acos(math.cos(phi) + (1 - math.cos(phi)) / 3))
        assert imu["error_deg_off"] == pytest.approx(math.degrees(phi), abs=1.0)
        assert imu["inclination_deg_off"] == pytest.approx(tilt, abs=1.0)
    off = [imu["error_deg_off"] for imu in result["imus"]]
    assert off == sorted(off) and off[-1] > 3 * off[0]


def test_with_correction_the_error_stays_bounded(drift):
    """Correction on (the hand-tracking paper, Fig. 12): under 2 degrees for every bias, inclination under 0.5."""
    result, _ = drift
    for imu in result["imus"]:
        assert imu["error_deg_on"] < 2.0
        assert imu["inclination_deg_on"] < 0.5
        assert imu["error_deg_on"] < imu["error_deg_off"] / 2


# --------------------------------------------------- the finger-tracking paper, sec. 3


def test_finger_grasp_shape_progress_and_json(grasp):
    result, messages = grasp
    assert result["durations_s"] == list(DURATIONS)
    assert set(result["series"]) == set(SERIES) == {"noise", "bias", "both"}
    for rms in result["series"].values():
        assert tuple(rms) == ALGORITHMS
        assert all(len(v) == len(DURATIONS) and all(x >= 0 for x in v) for v in rms.values())
    assert len(messages) == len(SERIES) * len(DURATIONS)
    assert json.loads(json.dumps(result)) == result


def test_finger_grasp_is_deterministic_for_a_seed():
    assert finger_grasp([0.5], seed=3) == finger_grasp([0.5], seed=3)


@pytest.mark.parametrize("series", ["bias", "both"])
def test_with_offsets_integration_wins_short_and_gravity_long_crossing_near_a_second(grasp, series):
    """The finger-tracking paper, sec. 3: with systematic errors integration outperforms gravity
    observation for short motions and loses for long ones, the crossover "on the order of one second".
    Checked: integration better at t_m <= 0.3 s, worse at t_m >= 3 s, the crossover
    (log-interpolated) between 0.3 and 3 s."""
    result, _ = grasp
    t, c = np.array(result["durations_s"]), curves(result, series)
    diff = np.log(c["integration"]) - np.log(c["gravity"])
    assert np.all(diff[t <= 0.3] < 0) and np.all(diff[t >= 3.0] > 0)
    k = int(np.argmax(diff > 0))
    crossing = math.exp(np.interp(0.0, diff[k - 1:k + 1], np.log(t[k - 1:k + 1])))
    assert 0.3 < crossing < 3.0


def test_with_white_noise_alone_integration_stays_better(grasp):
    """No offset, no linear drift: integration beats gravity over the whole reduced range (to 100 s)."""
    result, _ = grasp
    c = curves(result, "noise")
    assert np.all(c["integration"] < c["gravity"])


@pytest.mark.parametrize("series", sorted(SERIES))
@pytest.mark.parametrize("name", ["switching", "hinge"])
def test_the_filters_track_the_better_estimator(grasp, series, name):
    """The finger-tracking paper, Figure 10: both filters follow the better of gravity and integration,
    "only limited by the errors of the accelerometer". Checked: never more than ACC_LIMIT_DEG (4.9)
    above the better one (the switching filter from 0.5 s, within its gyroscope's range),
    and, with offsets, at least 10 times better than the worse one at both ends of the range."""
    result, _ = grasp
    t, c = np.array(result["durations_s"]), curves(result, series)
    best = np.minimum(c["gravity"], c["integration"])
    judged = t >= (SWITCHING_FROM_S if name == "switching" else 0.0)
    assert np.all(c[name][judged] <= best[judged] + ACC_LIMIT_DEG)
    if series != "noise":
        worst = np.maximum(c["gravity"], c["integration"])
        assert c[name][0] * 10 < worst[0] and c[name][-1] * 10 < worst[-1]


def test_white_noise_hurts_the_switching_filter_more(grasp):
    """The finger-tracking paper, sec. 3: "noise had a much greater influence on the simple switching
    algorithm"; the Madgwick-type filter dampens it. Checked in the white-noise series at the slowest motion
    (100 s, both filters at their noise floor): switching passes the accelerometer noise through
    (within 10% of gravity alone) and is at least 1.5 times the hinge filter's error."""
    result, _ = grasp
    c = curves(result, "noise")
    assert c["switching"][-1] == pytest.approx(c["gravity"][-1], rel=0.1)
    assert c["switching"][-1] > 1.5 * c["hinge"][-1]


# ---------------------------------------------------------------- figures


def require_matplotlib() -> None:
    """Skip without matplotlib, except in CI, which installs the plot extra and must draw."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        unavailable("matplotlib is not installed (pip install '.[plot]')", "the '.[plot]' extra must be installed")


def test_plots_are_written_as_png(drift, grasp, tmp_path):
    require_matplotlib()
    plot_static_drift(drift[0], tmp_path / "static.png")
    plot_finger_grasp(grasp[0], tmp_path / "grasp.png")
    for name in ("static.png", "grasp.png"):
        data = (tmp_path / name).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 1000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["grasp.png", "static.png"]  # no temporaries


def test_plots_without_matplotlib_say_how_to_install_it(drift, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)  # makes the import fail
    with pytest.raises(RuntimeError, match=r"matplotlib is not installed: pip install '\.\[plot\]'"):
        plot_static_drift(drift[0], tmp_path / "static.png")
    assert not any(tmp_path.iterdir())
