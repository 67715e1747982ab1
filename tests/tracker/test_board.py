"""The virtual board's quantisation, checked against the MPU-9250 scales worked by hand."""

import math

import numpy as np
import pytest

from tracker import protocol as P
from tracker.board import quantise
from tracker.motion import SensorReading


def test_quantise_matches_the_mpu9250_scales_worked_by_hand():
    # 1 g at +-16 g full scale is 32768 / 16 = 2048 counts; 1 rad/s at +-2000 deg/s is
    # 32768 / 2000 * 57.2958 = 938.7 counts; 15 uT is 100 counts at 0.15 uT/count.
    r = SensorReading(acc=(P.STANDARD_GRAVITY, 0, -1000.0), gyr=(1.0, 0, 0), mag=(15.0, 0, 0),
                      flex_deg=0, flex_adc=390, q=(1, 0, 0, 0))
    s = quantise(r, 0.0, 0, 0, 16, 2000)
    assert s.acc_counts == (2048, 0, -32768)  # saturates at the rail
    assert s.gyr_counts[0] == round(32768 / 2000 * math.degrees(1.0))
    assert s.mag_counts == (100, 0, 0)
    assert s.acc[0] == pytest.approx(P.STANDARD_GRAVITY)
    assert np.allclose(s.gyr, (1.0, 0, 0), atol=math.radians(2000) / 32768)
