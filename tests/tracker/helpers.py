"""Test helpers shared by the tracker tests."""

import time
from typing import Callable

from tracker import protocol as P


def wire(s: P.RawSample | P.FusedSample) -> tuple:
    """The fields a sample carries on the wire (host-side fields left out)."""
    if isinstance(s, P.RawSample):
        return (s.t_us, s.seq, s.acc_counts, s.gyr_counts, s.mag_counts, s.flex_adc,
                s.acc_fs_g, s.gyr_fs_dps)
    return (s.t_us, s.seq, s.q, s.flex_deg)


def wait_until(condition: Callable[[], bool], timeout: float = 5.0) -> bool:
    """Poll ``condition`` until it holds or ``timeout`` passes; whether it held."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.01)
    return condition()
