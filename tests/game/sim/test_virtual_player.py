"""The virtual board's player: it idles and throws without end, in constant memory."""

import numpy as np

from game.sim.motion_model import PlayerProfile
from game.sim.virtual_player import VirtualPlayer

RATE = 200.0


def readings(player: VirtualPlayer, seconds: float, start: float = 0.0):
    return [player.reading(start + k / RATE) for k in range(round(seconds * RATE))]


def test_the_player_raises_the_arm_and_throws_again_and_again():
    rs = readings(VirtualPlayer(RATE, seed=4), 60.0)
    flex = np.array([r.flex_deg for r in rs])
    # the ideally worn sensor's z runs up the arm: hanging still, the specific force lies along +z
    acc = np.array([r.acc for r in rs])
    tilt = np.degrees(np.arccos(np.clip(acc[:, 2] / np.linalg.norm(acc, axis=1), -1, 1)))
    throws = np.count_nonzero((flex[1:] < 25.0) & (flex[:-1] >= 25.0) & (tilt[1:] > 55.0))
    assert throws >= 3  # a gesture every 4-12 s or so
    assert tilt.min() < 20.0 and tilt.max() > 60.0  # it hangs the arm and raises it


def test_an_hour_of_play_keeps_the_script_small():
    player = VirtualPlayer(RATE, seed=1)
    readings(player, 5.0)
    early = sum(len(k) for k in player.script._keyframes._t.values())
    readings(player, 5.0, start=3600.0)  # the board's clock an hour on
    late = sum(len(k) for k in player.script._keyframes._t.values())
    assert late < 3 * early + 20


def test_the_same_seed_is_the_same_player_and_another_is_another():
    a, b, c = (readings(VirtualPlayer(RATE, PlayerProfile(), seed), 3.0) for seed in (7, 7, 8))
    assert [r.gyr for r in a] == [r.gyr for r in b]
    assert [r.gyr for r in a] != [r.gyr for r in c]
