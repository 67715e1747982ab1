"""Launches through the flex sensor's own dynamics: ADC -> FlexTracker -> GestureMachine.

The elbow angles are scripted here; the sensor's hysteresis and creep are
modelled here too, independently of the simulator's own model:

* hysteresis: the play (backlash) operator of Krasnosel'skii and Pokrovskii
  ("Systems with Hysteresis", 1989, sec. 2), y = min(x + r, max(x - r, y_prev)),
  whose loop is 2 r wide: the reading lags r behind the elbow in whichever
  direction it last moved;
* creep: the reading relaxes toward (1 - c) times itself with time constant
  tau while held (first order, discretised exactly), and back when released.

Widths and shares are the issue's worst case: 12 % of the sensor's 127 deg
straight-to-bent span for the loop, 12 % for the creep, tau 4 s.
"""

import math

import numpy as np
import pytest

from game.body.avatar import ArmState
from game.body.gestures import GestureMachine, GestureSettings
from game.sim.motion_model import minimum_jerk
from tracker.flex import FULL_BEND_DEG, FlexTracker, adc_from_degrees

RATE = 200.0
THRESHOLD = 25.0  # the true elbow crossing that a launch is timed from (gesture_eval)
POINTING = np.array([0.0, 1.0, 0.0])
ORIGIN = np.zeros(3)


def play(x, width):
    """The play operator of loop width ``width`` (degrees), starting centred on x[0]."""
    r, y, out = width / 2.0, float(x[0]), np.empty(len(x))
    for i, v in enumerate(x):
        y = min(v + r, max(v - r, y))
        out[i] = y
    return out


def creep(y, share, tau_s=4.0):
    """The reading y relaxing toward (1 - share) y with time constant tau_s, sampled at RATE."""
    k, z, out = 1.0 - math.exp(-1.0 / (RATE * tau_s)), 0.0, np.empty(len(y))
    for i, v in enumerate(y):
        z += k * (-share * v - z)
        out[i] = v + z
    return out


def sensor_reading(elbow, hysteresis=0.0, creep_share=0.0, noise_deg=0.0, seed=0):
    """What the flex sensor reports for the true elbow angles (degrees), before the circuit."""
    reading = creep(play(elbow, hysteresis * FULL_BEND_DEG), creep_share)
    return reading + np.random.default_rng(seed).normal(0.0, noise_deg, len(elbow))


def pipeline(adc, elevation, settings=None):
    """The events of a GestureMachine fed the ADC counts through a FlexTracker (arm pointing forward),
    and the tracked flex it saw."""
    tracker, machine, events, tracked = FlexTracker(), GestureMachine(settings), [], []
    for k, (count, el) in enumerate(zip(adc, elevation)):
        t = k / RATE
        tracked.append(tracker.update(int(count), t).deg)
        events += machine.update(ArmState(t, ORIGIN, ORIGIN, ORIGIN, ORIGIN, POINTING, float(el), tracked[-1]))
    return events, np.array(tracked)


def machine_events(adc, elevation, settings=None):
    return pipeline(adc, elevation, settings)[0]


class Script:
    """A session of true elbow angles and arm elevations at RATE, built move by move."""

    def __init__(self, rest=4.0):
        self.flex, self.elevation = [rest], [0.0]
        self.waves = []  # (start, true crossing of THRESHOLD, end) of every throw
        self.relaxations = []  # (start, end) of every slow straightening with the arm up

    @property
    def t(self):
        return (len(self.flex) - 1) / RATE

    def move(self, seconds, flex=None, elevation=None):
        """Minimum-jerk move of either channel over ``seconds`` (the other held)."""
        n = max(1, int(round(seconds * RATE)))
        s = minimum_jerk(np.arange(1, n + 1) / n)
        f0, e0 = self.flex[-1], self.elevation[-1]
        f1 = f0 if flex is None else flex
        e1 = e0 if elevation is None else elevation
        self.flex += list(f0 + (f1 - f0) * s)
        self.elevation += list(e0 + (e1 - e0) * s)

    def hold(self, seconds):
        self.move(seconds)

    def throw(self, seconds, straight):
        start, bent = self.t, self.flex[-1]
        self.move(seconds, flex=straight)
        end = self.t
        tt = np.linspace(start, end, 20001)
        x = bent + (straight - bent) * minimum_jerk((tt - start) / (end - start))
        self.waves.append((start, float(tt[np.argmax(x < THRESHOLD)]), end))

    def relax(self, seconds, straight):
        start = self.t
        self.move(seconds, flex=straight)
        self.relaxations.append((start, self.t))

    def arrays(self):
        return np.array(self.flex), np.array(self.elevation)


def session(seed, long_holds=False):
    """Raise, flex 75-120 deg, spin, throw (0.12-0.5 s) or now and then relax (3-5 s), reload, lower, idle bends."""
    rng = np.random.default_rng(seed)
    script = Script(rest=rng.uniform(2, 8))
    for _ in range(6):
        script.hold(rng.uniform(0.5, 1.5))
        script.move(rng.uniform(0.3, 0.6), elevation=rng.uniform(75, 105))
        for _ in range(int(rng.integers(1, 3))):
            script.hold(rng.uniform(0.2, 0.6))
            script.move(rng.uniform(0.25, 0.5), flex=rng.uniform(75, 120))
            script.hold(rng.uniform(2.0, 6.0) if long_holds else rng.uniform(0.3, 1.5))
            if rng.random() < 0.2:
                script.relax(rng.uniform(3.0, 5.0), rng.uniform(0, 6))
            else:
                script.throw(rng.uniform(0.12, 0.5), rng.uniform(0, 6))
        script.hold(rng.uniform(0.3, 0.8))
        script.move(rng.uniform(0.4, 0.8), elevation=0.0, flex=script.flex[0])
        for _ in range(2):  # an idle bend with the arm down: never a launch
            script.hold(rng.uniform(0.5, 1.5))
            script.move(rng.uniform(0.4, 0.8), flex=rng.uniform(30, 60))
            script.hold(rng.uniform(0.3, 1.0))
            script.move(rng.uniform(0.4, 0.8), flex=script.flex[0])
    script.hold(1.0)
    return script


def score(script, events):
    """(launches matched to throws, phantom launches, throws missed, relaxations that gave no "load")."""
    launches = [e.t for e in events if e.kind == "launch"]
    matched, phantom = 0, 0
    unmatched = list(script.waves)
    for t in launches:
        wave = next((w for w in unmatched if w[0] <= t <= w[2]), None)
        if wave is None:
            phantom += 1
        else:
            unmatched.remove(wave)
            matched += 1
    loads = [e.t for e in events if e.kind == "load"]
    unloaded = sum(not any(a <= t <= b + 0.1 for t in loads) for a, b in script.relaxations)
    return matched, phantom, len(unmatched), unloaded


@pytest.mark.parametrize("hysteresis, creep_share", [(0.0, 0.0), (0.12, 0.0), (0.0, 0.12), (0.12, 0.12)])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_throw_launches_before_the_elbow_is_straight_and_nothing_else_does(hysteresis, creep_share, seed):
    script = session(seed)
    flex, elevation = script.arrays()
    adc = adc_from_degrees(sensor_reading(flex, hysteresis, creep_share, noise_deg=0.5, seed=seed))
    events, tracked = pipeline(adc, elevation)
    matched, phantom, missed, unloaded = score(script, events)
    assert len(script.waves) >= 4 and script.relaxations
    # every throw launches within its wave, i.e. before the elbow has finished straightening
    assert (matched, phantom, missed, unloaded) == (len(script.waves), 0, 0, 0)
    # ... sooner after its tracked flex first read below flex-off than the dwell would allow: the quick
    # confirmation (at that very sample unless a slow or noisy step in the window makes it wait a little)
    s = GestureSettings()
    crossings = [(k + np.argmax(tracked[k:] < s.flex_off_deg)) / RATE
                 for k in (round(w[0] * RATE) for w in script.waves)]
    delays = np.array([e.t for e in events if e.kind == "launch"]) - crossings
    assert np.all(delays > -1e-9) and np.all(delays < s.flex_dwell_s - 1e-9)
    assert np.median(delays) == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("seed", [4, 5])
def test_creep_over_long_spins_neither_cancels_nor_misses_a_throw(seed):
    script = session(seed, long_holds=True)  # spins of 2-6 s: the reading creeps 5-9 deg toward straight
    flex, elevation = script.arrays()
    reading = sensor_reading(flex, 0.12, 0.12, noise_deg=0.5, seed=seed)
    assert np.min(reading[flex > 70] - flex[flex > 70]) < -15  # the loop and the creep both at work
    matched, phantom, missed, unloaded = score(script, machine_events(adc_from_degrees(reading), elevation))
    assert (matched, phantom, missed, unloaded) == (len(script.waves), 0, 0, 0)


def shallow_spin(hold_s, creep_share):
    """Raise, flex to 66 deg, hold, throw in 0.15 s: the reading (12 % loop) starts 7.6 deg below the elbow."""
    script = Script()
    script.hold(0.5)
    script.move(0.4, elevation=90.0)
    script.hold(0.3)
    script.move(0.3, flex=66.0)
    script.hold(hold_s)
    script.throw(0.15, 2.0)
    script.hold(0.5)
    flex, elevation = script.arrays()
    reading = sensor_reading(flex, 0.12, creep_share)
    return script, reading, machine_events(adc_from_degrees(reading), elevation)


def test_creep_sagging_a_shallow_spin_below_flex_on_does_not_cancel_it():
    script, reading, events = shallow_spin(5.0, 0.12)
    s = GestureSettings()
    wave_start = int(round(script.waves[0][0] * RATE))
    # the reading crept below flex-on more than max_straighten_s before the throw began
    sagged = np.flatnonzero(reading[:wave_start] > s.flex_on_deg)[-1]
    assert (wave_start - sagged) / RATE > s.max_straighten_s
    assert [e.kind for e in events] == ["load", "spin", "launch"]
    # without the allowance for the sag, the same spin is taken for a relaxation
    strict = machine_events(adc_from_degrees(reading), script.arrays()[1], GestureSettings(hold_sag=0.0))
    assert [e.kind for e in strict] == ["load", "spin", "load"]


def test_a_shallow_spin_without_creep_throws_the_same():
    assert [e.kind for e in shallow_spin(5.0, 0.0)[2]] == ["load", "spin", "launch"]


def test_a_real_straightening_reads_below_flex_off_despite_the_loop():
    # after a throw to 6 deg the reading stays 7.6 deg bent (the loop's half width), well below flex-off
    script = Script(rest=6.0)
    script.move(0.3, flex=110.0)
    script.hold(0.5)
    script.throw(0.2, 6.0)
    script.hold(1.0)
    reading = sensor_reading(np.array(script.flex), 0.12)
    assert reading[-1] == pytest.approx(6.0 + 0.06 * FULL_BEND_DEG)
    assert reading[-1] < GestureSettings().flex_off_deg


@pytest.mark.parametrize("width", [1, 2, 3])
@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_adc_glitches_during_a_spin_launch_nothing(width, seed):
    # spinning at 90 deg for 3 s; glitches of one to three samples jump the ADC to a straight arm's count
    script = Script()
    script.hold(0.5)
    script.move(0.4, elevation=90.0)
    script.hold(0.3)
    script.move(0.3, flex=90.0)
    script.hold(3.0)
    flex, elevation = script.arrays()
    adc = adc_from_degrees(sensor_reading(flex, 0.04, 0.03, noise_deg=0.5, seed=seed))
    rng = np.random.default_rng(seed)
    straight = adc_from_degrees(rng.uniform(-10, 5))
    for start in rng.choice(np.arange(int(2.0 * RATE), len(adc) - 10, 25), size=8, replace=False):
        adc[start:start + width] = straight
    assert [e.kind for e in machine_events(adc, elevation)] == ["load", "spin"]


def test_the_quick_confirmation_reports_a_fast_wave_sooner_than_the_dwell():
    # the same throw with the quick path on and off: on, the launch comes the sample the reading crosses
    script = Script()
    script.hold(0.5)
    script.move(0.4, elevation=90.0)
    script.hold(0.3)
    script.move(0.3, flex=100.0)
    script.hold(0.8)
    script.throw(0.2, 3.0)
    script.hold(0.5)
    flex, elevation = script.arrays()
    adc = adc_from_degrees(flex)
    quick = [e for e in machine_events(adc, elevation) if e.kind == "launch"]
    slow = [e for e in machine_events(adc, elevation, GestureSettings(wave_speed_dps=math.inf))
            if e.kind == "launch"]
    s = GestureSettings()
    assert len(quick) == len(slow) == 1
    assert slow[0].t - quick[0].t == pytest.approx(s.flex_dwell_s, abs=0.5 / RATE)
    tracker = FlexTracker()
    tracked = [tracker.update(int(c), k / RATE).deg for k, c in enumerate(adc)]
    crossing = next(k for k, f in enumerate(tracked) if k / RATE > script.waves[0][0] and f < s.flex_off_deg)
    assert quick[0].t == pytest.approx(crossing / RATE)
