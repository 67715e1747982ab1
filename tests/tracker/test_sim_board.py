"""The simulated board's bytes against the firmware's rule applied sample by sample."""

from __future__ import annotations

from tracker import protocol as P
from tracker.board import BoardSettings, quantise
from tracker.sim import SimulatedSource, arm_chain, arm_swing, realistic_errors, Simulator
from tracker.sim_board import SimBoard


def _simulator(seed: int) -> Simulator:
    return Simulator(arm_chain(), arm_swing(), realistic_errors(), seed=seed)


def _frames_one_by_one(seed: int, n: int) -> bytes:
    """Each sample read on its own (the virtual board's source), quantised and framed as the firmware does:
    a TEMP frame before the first RAW frame and before every 200th (once a second, PROTOCOL.md sec. 4.3)."""
    source, s = SimulatedSource(_simulator(seed), rate_hz=200.0), BoardSettings()
    out = b""
    for k in range(n):
        raw = quantise(source.reading(k / 200.0), k / 200.0, round(k * 5000), k, s.acc_fs_g, s.gyr_fs_dps)
        if k % 200 == 0:
            out += P.encode_temp(raw.t_us, raw.temp_counts)
        out += P.encode_raw(raw)
    return out


def test_the_boards_frames_are_each_sample_quantised_and_framed_whatever_the_block():
    expected = _frames_one_by_one(seed=3, n=1000)  # 5 s: the default block (800 samples) and a part
    for block in (800, 7):
        assert SimBoard(_simulator(3), block=block).run_until(999 / 200.0) == expected
