"""The virtual board: quantisation checked against the MPU-9250 scales worked by hand; link faults."""

import math

import numpy as np
import pytest

from tracker import protocol as P
from tracker.board import FaultInjector, Faults, quantise
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


def test_fault_specs_parse_and_bad_ones_say_what_is_wrong():
    f = Faults.parse("corrupt=0.01, drop=0.002,stall=0.5@20,stall=1@5", seed=3)
    assert (f.corrupt_rate, f.drop_rate, f.seed) == (0.01, 0.002, 3)
    assert f.stalls == ((5.0, 1.0), (20.0, 0.5))
    assert f.stalled(20.2) and f.stalled(5.0) and not f.stalled(20.5) and not f.stalled(4.99)
    assert Faults.parse("") == Faults()
    for bad in ("corrupt=1.5", "drop=x", "stall=0.5", "stall=-1@3", "heat=1"):
        with pytest.raises(ValueError, match="fault"):
            Faults.parse(bad)


def test_the_injector_counts_what_it_did_at_the_rates_asked():
    injector = FaultInjector(Faults(corrupt_rate=0.01, drop_rate=0.002, seed=1))
    data = bytes(range(256)) * 400  # 102400 bytes
    out = injector.apply(data)
    assert len(out) == len(data) - injector.bytes_dropped
    assert injector.bytes_dropped == pytest.approx(0.002 * len(data), rel=0.2)
    assert injector.bytes_corrupted == pytest.approx(0.01 * len(data) * 0.998, rel=0.1)
    assert FaultInjector(Faults()).apply(data) == data
