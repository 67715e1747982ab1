"""`armtracker monitor` runs the default filter on the raw samples and says what it makes of the
magnetometer (issue 12)."""

import json
import math

from tracker import protocol as P
from tracker.__main__ import MonitorFusion

from .test_cli import armtracker

RATE = 200.0
ACC_COUNT = 16 * P.STANDARD_GRAVITY / 32768.0  # m/s^2 per count at 16 g
GYR_COUNT = math.radians(2000) / 32768.0  # rad/s per count at 2000 deg/s


def turning_board(seconds: float, hard_iron_ut: tuple[float, float, float]) -> list[P.RawSample]:
    """Raw samples of a level board turning about its x axis at 0.5 rad/s in the field
    (0, 20, -40) uT, its magnetometer offset by a hard iron."""
    out = []
    for k in range(int(seconds * RATE)):
        a = 0.5 * k / RATE
        c, s = math.cos(a), math.sin(a)
        acc = (0.0, 9.81 * s, 9.81 * c)
        mag = (hard_iron_ut[0], 20 * c - 40 * s + hard_iron_ut[1], -20 * s - 40 * c + hard_iron_ut[2])
        out.append(P.RawSample(k / RATE, round(k * 1e6 / RATE), k & 0xFFFF,
                               tuple(round(x / ACC_COUNT) for x in acc), (round(0.5 / GYR_COUNT), 0, 0),
                               tuple(round(x / P.MAG_UT_PER_COUNT) for x in mag), 500))
    return out


def test_monitor_fusion_says_when_the_magnetometer_is_off():
    fusion = MonitorFusion()
    assert fusion.status == ""  # nothing seen yet
    fusion.feed(P.FusedSample(0.0, 0, 0, (1.0, 0.0, 0.0, 0.0), 0.0))  # the board's own fusion: not ours
    assert fusion.status == ""
    for s in turning_board(20.0, (0.0, 0.0, 0.0)):
        fusion.feed(s)
    assert fusion.status == "magnetometer on"
    assert abs(fusion.filter.get_state().bias[0]) < math.radians(0.2)  # the time steps came from t
    for s in turning_board(20.0, (60.0, 30.0, 0.0)):
        fusion.feed(s)
    assert fusion.status.startswith("magnetometer off: field strength changes as the board moves")


def test_monitor_reports_the_magnetometer_in_its_json():
    r = armtracker("monitor", "--virtual", "--seconds", "1.5", "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert report["magnetometer"].startswith("magnetometer ")
