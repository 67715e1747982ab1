"""``default``: EnergyBall's own filter, the one the game uses.

Its structure follows the published VQF method (D. Laidig and T. Seel, "VQF:
Highly accurate IMU orientation estimation with bias estimation and magnetic
disturbance rejection", Information Fusion 91, 2023; cited below as VQF),
written afresh from the paper's description, with a bias estimator in motion
after Mahony's integral term (R. Mahony, T. Hamel, J.-M. Pflimlin, "Nonlinear
complementary filters on the special orthogonal group", IEEE TAC 53(5), 2008;
cited as Mahony). Each step of :meth:`DefaultFilter._step` says which.

The orientation is kept as three factors (VQF sec. 3)::

    q_WS = q_heading (about world z)  *  q_inc (I -> E, no heading)  *  q_gyr (S -> I)

``q_gyr`` is pure strapdown integration of the bias-corrected gyroscope into
an almost-inertial frame I (each turn led to undo the chip's low-pass, which
would turn a tremor's coning into drift: ``gyro_lead_s``). The accelerometer,
rotated into I, is low-pass filtered there: in I the gravity direction moves
only as slowly as q_gyr drifts, while linear accelerations of real motion
average out. ``q_inc`` is the rotation that makes this filtered direction
vertical. ``q_heading`` turns the horizontal part of the magnetic field, seen
in the 6D frame, to north.

Two things hold up on a real player with a real board:

- The gyroscope bias is a small Kalman-style estimate (VQF sec. 3.3, "rest
  bias estimation" and "motion bias estimation"): a 3x3 covariance says how
  well each direction of the bias is known. In motion the inclination
  correction observes the two horizontal components (Mahony eq. 32's
  integral term, with a gain per direction); as the arm turns, every sensor
  axis takes its turn at being horizontal, and the covariance gives the one
  that was vertical the larger gain. At rest (judged on low-passed signals,
  so that a tremor does not hide it) the low-passed gyroscope observes all
  three. The uncertainty grows back when nothing observes it, and the
  bias's rate of change is estimated with it (a second Kalman state, a
  type-2 loop), so the estimate follows the MPU-9250's warm-up drift
  without lagging it, while a bias that starts unknown is found as offset.
  The gyroscope's residual sensitivity (what the maker's calibration left of
  its scale and cross-axis errors) is a third state the same corrections
  teach once the arm has stopped (:mod:`tracker.fusion.sensitivity`).
  Told that the board has just powered up (:meth:`DefaultFilter.power_on`,
  from the board's clock), the drift starts as unknown as the warm-up makes
  it, so the steepest part of the warm-up is learned, not lagged.
- The magnetometer is used only while its field is consistent: with a
  hard-iron offset or a soft-iron distortion (an uncalibrated board) or an
  indoor disturbance that changes with position, the field's norm and dip
  change as the board turns (VQF sec. 3.4 tests norm and dip sample by
  sample against an adapting reference; here their spread over a window is
  judged as well). A field found inconsistent is switched off (heading from
  the gyroscope alone; :attr:`DefaultFilter.status` says why) until it has
  stayed consistent for a while with the board turning. A field switched on
  again is on probation: it turns the heading slowly for ``mag_on_t``, and
  if it is found bad within ``mag_trust_t`` of use (twice that), what it
  taught is taken back (as is what a field still being checked settled
  since the heading was taken as a reference), so it leaves the pose as no
  magnetometer would have. A disturbance that varies with position can
  also turn the field's direction while its norm and dip stay the same: the
  heading innovation (the field's heading against the gyroscope's) then
  spreads as the arm moves, and the field counts as much less as a Kalman
  gain would for that noise (x-io Fusion's magnetic rejection judges the
  same innovation; here it weighs rather than switches). A field that passes its check and is
  found bad again, time after time, is a room whose field varies from place
  to place: each such refutation makes it count less
  (:meth:`DefaultFilter._heading_weight`), until the heading is the
  gyroscope's, as without a magnetometer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from mypy_extensions import mypyc_attr

from ..calibration import RestDetector, RestParams
from ..lowpass import LowPass2
from ..mpu_dlpf import Dlpf
from .base import Filter
from .qmath import IDENTITY, Quat, Vec, about_z, cross, from_rotvec, integrate, mul, normalize, rotate, tilt_to_up
from .sensitivity import Sensitivity
from .start import StartMean

GRAVITY = 9.81
BIAS_EVERY = 4  # samples per update of the bias in motion
SHOULDER_SENS_PRIOR = 40.0  # sens_prior for an accelerometer moved to the shoulder (for_mpu9250)
SHOULDER_TURN_RATE = 0.5  # bias_turn_rate and bias_turned_rate there, rad/s (for_mpu9250)
Sym3 = tuple[float, float, float, float, float, float]  # a symmetric 3x3 matrix: xx, xy, xz, yy, yz, zz
Mat3 = tuple[float, float, float, float, float, float, float, float, float]  # a 3x3 matrix by rows

MAG_STRENGTH = "field strength changes as the board moves (uncalibrated or disturbed?)"
MAG_DIP = "field direction changes as the board moves (uncalibrated or disturbed?)"
MAG_WEAK = "magnetometer weak: its heading wanders as the board moves (disturbed?)"


def _limit(x: float, y: float, z: float, m: float) -> Vec:
    """(x, y, z) limited to +-m per axis: max(-m, min(m, .)) as conditionals (NaN included; no
    builtin calls in the compiled build)."""
    x, y, z = (x if x < m else m), (y if y < m else m), (z if z < m else m)
    return (x if x > -m else -m), (y if y > -m else -m), (z if z > -m else -m)


@dataclass(frozen=True)
class DefaultParams:
    """Settings of the default filter (times in seconds, thresholds in SI units).

    Bias: the MPU-9250's zero-rate offset is within +-5 deg/s at 25 degC and
    moves by up to +-30 deg/s over its temperature range (PS-MPU-9250A-01 rev.
    1.1, table 1; a player profile's gyro_bias_dps allows 30), and drifts by up
    to 4 deg/s more as the board warms over its first minutes, hence
    ``bias_max`` of 35 deg/s, the start-up hold's own bound.
    ``bias_tau_min`` is the fastest the motion estimate may follow: the
    correction it learns from comes through the accelerometer's low-pass of
    ``tau_acc``, and an integral loop around a second-order low-pass of
    time constant 3 s keeps a phase margin above 50 degrees only below about
    0.2 rad/s. Rest: a tremor of 2 deg at 3-12 Hz (up to 150 deg/s) is cut by
    the 1 s low-pass ``rest_lp_tau`` to 0.2 deg/s at most (second-order
    roll-off from 0.23 Hz), under ``rest_gyr_th``.

    Drift: the warm-up moves the bias by up to 4 deg/s over 10 minutes along a
    first-order thermal curve of time constant 150-300 s (the board's heat
    capacity over its thermal resistance), so at most 0.027 deg/s per s at
    power-on: ``drift_max`` 0.05. The drift is a second state beside the bias
    (bias' = drift, drift' = -drift / drift_tau + w): a random walk w of
    spectral density 1 / drift_t^4 (in the units of ``bias_p``) gives the
    steady-state Kalman loop of a measured double integrator a natural
    frequency of 1 / drift_t and damping 1 / sqrt(2) (P. Zarchan and H. Musoff,
    "Fundamentals of Kalman Filtering", 4th ed., sec. 4, the two-state
    polynomial filter), slow beside the warm-up's 150 s and fast beside the
    bias loop's own noise. 15 s, not faster: on the real recordings of BROAD
    (9D) a drift_t of 10 s learns noise (mean total error 1.27 deg against
    VQF's 1.26), 15 s gives 1.23; 6D play in the magnetic room drifts a few
    degrees more than at 10 s (at power-on, :meth:`DefaultFilter.power_on` starts the
    drift loop fast instead). ``drift_tau`` lets it fade as the warming does (the
    longer end of the range: the loop corrects a drift that fades sooner).
    ``drift_settle_t``: motion teaches the drift only once the bias loop's response
    to the start has settled (:meth:`DefaultFilter._learn_bias_in_motion`): the
    loop, 1 / ``bias_tau_min`` behind the accelerometer's ``tau_acc`` low-pass
    with a phase margin of about 50 degrees (damping about 0.5), settles a step
    to 2 % in about 4 / (0.5 / 3 s), some 20 s.
    """

    tau_acc: float = 3.0  # low-pass time constant of the accelerometer in frame I (VQF sec. 3.2)
    tau_mag: float = 15.0  # heading correction time constant (VQF sec. 3.4: 9 s; 15 keeps BROAD 9D under VQF)
    tau_mag_probation: float = 60.0  # ... while a field just switched on is on probation (mag_on_t)
    rest_lp_tau: float = 1.0  # the rest test low-passes gyro and accelerometer first (VQF sec. 3.3)
    rest_gyr_th: float = math.radians(0.5)  # rest: the low-passed gyro varies less than this (rad/s)
    rest_acc_th: float = 0.2  # rest: the low-passed accelerometer varies less than this (m/s^2)
    rest_min_t: float = 1.5  # rest: held this long (VQF sec. 3.3)
    rest_max_rate: float = math.radians(5.0)  # rest: the low-passed bias-corrected rate below this on
    # every axis (rad/s): a slow steady turn is no rest; 5 deg/s, the MPU-9250's zero-rate tolerance,
    # leaves room for a bias not yet learned
    rest_tau: float = 0.5  # low-pass time constant of the rest detector's signals (VQF sec. 3.3)
    bias_tau_min: float = 3.0  # the bias estimate's fastest time constant in motion, s
    bias_tau_rest: float = 1.0  # its time constant at rest while the bias is least known, s
    bias_turn_rate: float = 0.25  # turning this fast (rad/s, low-passed) halves what motion tells of the bias
    bias_turned_rate: float = 0.25  # ... and so does having turned this fast over the last tau_acc (the rate
    # low-passed as the accelerometer is): the tilt a turn leaves (DefaultFilter._learn_bias_in_motion)
    sens_prior: float = 0.0  # the gyroscope's residual sensitivity's prior covariance per entry, in bias_p's
    # units per (rad/s)^2; 0: not learned. Only an accelerometer moved to the centre of rotation has
    # no accelerations that correlate with the rate: SHOULDER_SENS_PRIOR (tracker.fusion.sensitivity;
    # README, "The gyroscope's residual sensitivity")
    sens_still_rate: float = 0.25  # ... and learned only while the rate low-passed over rest_lp_tau is below
    # this (rad/s): the arm has stopped (tracker.fusion.sensitivity)
    sens_limit: float = 0.005  # |entry| bound: 2.5 times the 0.2 % a maker's calibration leaves at worst
    sens_start_t: float = 60.0  # the residual is learned from this long after the start, once the bias loop
    # has taken out most of what the start left (from 5 deg/s off: within 1 deg/s after 33 s, README)
    bias_forget_t: float = 20.0  # a bias direction nothing observes is unknown again after about this, s
    bias_max: float = math.radians(35.0)  # |bias| limit per axis: zero-rate output over temperature
    drift_t: float = 15.0  # the drift's random walk makes the bias loop follow a ramp within about this, s
    drift_tau: float = 300.0  # a learned drift fades with the board's thermal time constant (150-300 s)
    drift_max: float = math.radians(0.05)  # |drift| limit per axis (rad/s per s): 4 deg/s of warm-up at 150 s
    drift_settle_t: float = 20.0  # a calibrated warm-up's drift is taught by motion only this long after the start, s
    acc_lead_s: float = 0.0  # how much more recent the accelerometer's reading is than the gyroscope's, s
    # (the MPU-9250's low-pass filters delay them differently: tracker.mpu_dlpf, 1.02 ms at 200 Hz)
    gyro_lead_s: float = 0.0  # each sample's turn is led by this much of the rate's change, s: gives a tremor
    # back the amplitude the gyroscope's low-pass took, whose coning it would otherwise integrate as a drift
    # (tracker.mpu_dlpf.Response.amplitude_lead_s, 2.12 ms at 200 Hz; 0: the rates as read)
    mag_norm_th: float = 0.1  # field norm deviating by more than this fraction: disturbed
    mag_dip_th: float = math.radians(10.0)  # dip angle deviating by more than this: disturbed
    mag_ref_tau: float = 20.0  # how fast the undisturbed field reference (norm, dip) adapts
    mag_window_t: float = 5.0  # the window (time constant) over which the field's consistency is judged
    mag_norm_sd_th: float = 0.05  # field unusable: the norm's spread over the window beyond this fraction
    mag_dip_sd_th: float = math.radians(15.0)  # field unusable: the dip's spread beyond this (rad; above
    # what inclination errors while the bias is still being learned give a good field)
    mag_judge_t: float = 1.5  # the field is judged once this much of the window has filled
    mag_turn_th: float = 0.1  # "the board has turned": spread of its axes over the window (rad^2)
    mag_on_t: float = 15.0  # the field is used (again) after being consistent this long while turning
    mag_trust_t: float = 30.0  # ... and what it teaches is taken back if it is found bad within this long
    # of use (DefaultFilter._remember_field): twice mag_on_t
    mag_head_lp_tau: float = 0.5  # the heading innovation is low-passed this much before its spread is judged
    mag_held_t: float = 0.05  # a reading equal to the last is the board's held one, used at least this often
    mag_head_sd: float = math.radians(2.0)  # a field whose heading spreads up to this turns the heading at
    # tau_mag; one that spreads s > this, s / this times more slowly (a steady-state Kalman gain).
    # BROAD's undisturbed real recordings spread 0.7-1.3 deg (median), 1.0-3.1 (90th percentile)
    mag_weak_sd: float = math.radians(6.0)  # a field in use whose heading spreads more is weak (status,
    # mag_unusable): it counts a third or less; BROAD's undisturbed real fields spread at most 3.7 deg
    startup_t: float = 1.0  # during the first second corrections use plain averaging (fast start)


@mypyc_attr(serializable=True)  # copy.deepcopy works when compiled (its __init__ needs arguments)
@dataclass
class DefaultState:
    """Everything the default filter has learned (read with get_state, restore with set_state)."""

    acc_lp: LowPass2  # the accelerometer in frame I, low-passed
    rest_gyr: LowPass2  # the gyroscope low-passed for the rest test (sensor frame)
    rest_acc: LowPass2  # the accelerometer low-passed for the rest test (sensor frame)
    rest: RestDetector  # judges the low-passed signals
    bias_p: Sym3  # how well the bias is known: its covariance over the motion measurement's noise, 1/s
    bias_lp_r0: LowPass2  # R_IS (strapdown, by rows) low-passed as the accelerometer in I is
    bias_lp_r1: LowPass2
    bias_lp_r2: LowPass2
    bias_lp_rb: LowPass2  # R_IS b_est low-passed alike
    head_lp: LowPass2  # the heading innovation as a unit vector (cos, sin, 0), low-passed
    turned_lp: LowPass2  # the bias-corrected rate low-passed as the accelerometer in I is: the recent turn
    sens: Sensitivity  # the gyroscope's residual sensitivity, learned in play
    rate_last: Vec | None = None  # the last sample's corrected rate (gyro_lead_s), None before the first
    rate_sum: Vec = (0.0, 0.0, 0.0)  # the corrected rate's integral since the last bias update
    tilt_sum: tuple[float, float] = (0.0, 0.0)  # the inclination corrections since the last bias update
    tilt_dt: float = 0.0  # over this long (s) ...
    tilt_n: int = 0  # ... in this many samples
    q: Quat = IDENTITY  # the output, q_WS
    q_gyr: Quat = IDENTITY  # strapdown S -> I
    q_inc: Quat = IDENTITY  # inclination correction I -> E
    heading: float = 0.0  # rotation about world z, radians
    bias: Vec = (0.0, 0.0, 0.0)  # gyroscope bias, rad/s, sensor frame
    drift: Vec = (0.0, 0.0, 0.0)  # the bias's rate of change as the board warms, rad/s per s
    drift_p: Sym3 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # the drift's covariance, in bias_p's units per s^2
    cross_p: Mat3 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # bias-drift covariance, row i bias_i
    warmup_calibrated: bool = False  # power_on said a thermal calibration corrects the warm-up (most of it)
    t: float = 0.0  # time since start
    start: StartMean = field(default_factory=StartMean)  # the accelerometer in I over the start-up
    mag_norm: float = 0.0  # reference field norm (uT), 0 until known
    mag_dip: float = 0.0  # reference dip angle (rad)
    mag_samples: int = 0  # undisturbed magnetometer samples used so far
    mag_t: float = 0.0  # seconds of magnetometer samples seen (the window fills)
    mag_last: Vec = (0.0, 0.0, 0.0)  # the last magnetometer reading used ...
    mag_dt: float = 0.0  # ... and the seconds since
    win_norm: float = 0.0  # the window's mean field norm (uT) ...
    win_norm_var: float = 0.0  # ... and its variance (uT^2)
    win_dip: float = 0.0  # the window's mean dip (rad) ...
    win_dip_var: float = 0.0  # ... and its variance (rad^2)
    win_y: Vec = (0.0, 0.0, 0.0)  # the window's mean of world y in the sensor frame
    win_z: Vec = (0.0, 0.0, 0.0)  # and of world z: how far the board turned
    win_head: tuple[float, float] = (1.0, 0.0)  # ... its window's mean: its length says how it spreads
    mag_good_t: float = 0.0  # seconds an unusable field has been consistent while turning
    mag_checked: bool = False  # the field has proved consistent while the board turned
    mag_reason: str = ""  # why the magnetometer is off ("": not found inconsistent)
    mag_refuted: int = 0  # times a field that had passed its check was found bad afterwards
    mag_use_t: float = 0.0  # seconds the field has been in use since it was last switched on
    taught_heading: float = 0.0  # the heading turns a field not yet trusted made (rad) ...
    taught_bias: Vec = (0.0, 0.0, 0.0)  # ... and the bias it taught: taken back if it is found bad
    taken_back: int = 0  # times what a field not yet trusted had taught was taken back
    referenced: bool = False  # the heading was taken as a reference (reference_taken)


class DefaultFilter(Filter[DefaultParams, DefaultState]):
    """EnergyBall's default filter: VQF-style inclination and heading, bias at rest and in motion."""

    name = "default"
    Params = DefaultParams
    State = DefaultState

    def _initial_state(self) -> DefaultState:
        p = self.params
        # The rest detector is fed the bias-corrected rate: a steady turn is no rest, whatever the bias.
        rest = RestDetector(RestParams(p.rest_gyr_th, p.rest_acc_th, p.rest_max_rate, p.rest_min_t, p.rest_tau))
        k = 1.0 / p.bias_tau_min
        return DefaultState(LowPass2(p.tau_acc), LowPass2(p.rest_lp_tau), LowPass2(p.rest_lp_tau), rest,
                            (k, 0.0, 0.0, k, 0.0, k), LowPass2(p.tau_acc), LowPass2(p.tau_acc),
                            LowPass2(p.tau_acc), LowPass2(p.tau_acc), LowPass2(p.mag_head_lp_tau),
                            LowPass2(p.tau_acc), Sensitivity(p.tau_acc, p.sens_prior, p.sens_limit))

    @property
    def status(self) -> str:
        """The magnetometer's use in words: "magnetometer on", "magnetometer off: <why>",
        "magnetometer being checked" (its field not yet consistent for ``mag_on_t``; the heading
        is the gyroscope's meanwhile), :data:`MAG_WEAK` (in use, but it counts a third or less:
        :attr:`field_weight`) or "no magnetometer" (none seen yet)."""
        s = self._state
        if s.mag_reason:
            return "magnetometer off: " + s.mag_reason
        if not s.mag_samples:
            return "no magnetometer"
        if not s.mag_checked:
            return "magnetometer being checked"
        return MAG_WEAK if self._weak() else "magnetometer on"

    @property
    def heading(self) -> float:
        """The heading's turn about world z (rad): what the magnetometer has turned so far."""
        return self._state.heading

    @property
    def bias(self) -> Vec:
        """The gyroscope bias estimated so far (rad/s, sensor frame)."""
        return self._state.bias

    @property
    def heading_spread(self) -> float:
        """How the field's heading has spread against the gyroscope's over the last
        ``mag_window_t`` (rad, a standard deviation; :meth:`_heading_weight`)."""
        hx, hy = self._state.win_head
        return math.sqrt(max(0.0, 2.0 * (1.0 - math.sqrt(hx * hx + hy * hy))))

    @property
    def field_weight(self) -> float:
        """How much the field's heading counts now, 1 at most: less as its heading spreads
        beyond ``mag_head_sd`` and each time it was found bad after its check (:meth:`_heading_weight`)."""
        spread, sd = self.heading_spread, self.params.mag_head_sd
        return (1.0 if spread <= sd else sd / spread) / (1.0 + self._state.mag_refuted)

    def _weak(self) -> bool:
        """The field counts less than a field whose heading spreads ``mag_weak_sd`` would."""
        p = self.params
        return self.field_weight < p.mag_head_sd / p.mag_weak_sd

    def _step(self, gyr: Vec, acc: Vec | None, mag: Vec | None, dt: float) -> Quat:
        s, p = self._state, self.params
        s.t += dt
        self._forget_bias(dt)
        self._drift_bias(dt)
        if acc is not None:
            self._detect_rest(gyr, acc, dt)
        # 1. Strapdown integration of the bias-corrected rate (VQF sec. 3.1), led as the gyroscope's
        #    low-pass asks (Mark and Tazartes 2000: _led).
        b = s.bias
        w = (gyr[0] - b[0], gyr[1] - b[1], gyr[2] - b[2])
        learn_sens = p.sens_prior > 0.0
        if learn_sens:
            w = s.sens.correct(w)
        s.q_gyr = normalize(integrate(s.q_gyr, self._led(w, dt), dt))
        s.turned_lp.step(w, dt)
        # 2. Inclination from the accelerometer low-passed in frame I (VQF sec. 3.2),
        #    and the bias from the correction while in motion (VQF sec. 3.3, Mahony eq. 32).
        tilt = self._correct_inclination(acc, w, dt) if acc is not None else None
        q6 = mul(s.q_inc, s.q_gyr)
        if tilt is not None and not self.flags.rest and s.t > p.startup_t:
            # The correction, summed over BIAS_EVERY samples, teaches the bias (a 3 s loop needs no more).
            cx, cy = s.tilt_sum
            s.tilt_sum, s.tilt_dt, s.tilt_n = (cx + tilt[0], cy + tilt[1]), s.tilt_dt + dt, s.tilt_n + 1
            if learn_sens:
                ws = s.rate_sum
                s.rate_sum = (ws[0] + w[0] * dt, ws[1] + w[1] * dt, ws[2] + w[2] * dt)
            if s.tilt_n == BIAS_EVERY:
                (cx, cy), t, (wx, wy, wz) = s.tilt_sum, s.tilt_dt, s.rate_sum
                rate = (wx / t, wy / t, wz / t) if learn_sens else None
                self._learn_bias_in_motion(cx / t, cy / t, rate, t, not s.warmup_calibrated or s.t > p.drift_settle_t)
                s.tilt_sum, s.tilt_dt, s.tilt_n, s.rate_sum = (0.0, 0.0), 0.0, 0, (0.0, 0.0, 0.0)
        # 3. Heading from the magnetometer, with disturbance rejection (VQF sec. 3.4). The AK8963
        #    measures at 100 Hz and the board sends its latest reading with every sample: a reading
        #    sent again tells nothing new, and turned by this sample's orientation it would misstate
        #    the heading by the turn since it was made, so it waits, its time added to the next one's.
        if mag is not None:
            s.mag_dt += dt
            if mag != s.mag_last or s.mag_dt >= p.mag_held_t:  # (a still board's readings may repeat)
                self._correct_heading(q6, mag, s.mag_dt)
                s.mag_last, s.mag_dt = mag, 0.0
        self.flags.mag_unusable = s.mag_reason != "" or (s.mag_checked and self._weak())
        s.q = normalize(mul(about_z(s.heading), q6))
        return s.q

    def _led(self, w: Vec, dt: float) -> Vec:
        """The rate whose turn over ``dt`` is w dt + L (w - w_last), L = ``gyro_lead_s``: the
        gyroscope's low-pass undone to second order in frequency, so a tremor's coning is taken
        back as the arm made it (:meth:`tracker.mpu_dlpf.Response.amplitude_lead_s`). The first
        sample has nothing to lead from."""
        s, lead = self._state, self.params.gyro_lead_s
        last, s.rate_last = s.rate_last, w
        if lead == 0.0 or last is None:
            return w
        k = lead / dt
        return w[0] + k * (w[0] - last[0]), w[1] + k * (w[1] - last[1]), w[2] + k * (w[2] - last[2])

    # ------------------------------------------------------------ rest and bias

    def _detect_rest(self, gyr: Vec, acc: Vec, dt: float) -> None:
        """Rest when the low-passed gyro and accelerometer stay steady (VQF sec. 3.3, on
        signals low-passed first so a tremor averages out); then the low-passed gyro is the bias."""
        s, p = self._state, self.params
        g = s.rest_gyr.step(gyr, dt)
        b = s.bias
        rest = s.rest.update((g[0] - b[0], g[1] - b[1], g[2] - b[2]), s.rest_acc.step(acc, dt), dt)
        self.flags.rest = rest
        if rest:
            r = p.bias_tau_rest / p.bias_tau_min / dt  # the rest measurement's noise, as the motion's is 1/dt
            for axis, h in enumerate(((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))):
                self._observe_bias(h, g[axis] - b[axis], r, drift=False)

    def _forget_bias(self, dt: float) -> None:
        """The bias's uncertainty grows back toward "unknown" (1 / bias_tau_min) over bias_forget_t.

        P <- (1 - a) P + a P_max I, a = dt / T (the bias-drift covariance times 1 - a,
        the drift's kept): a convex blend, so P stays a covariance and P_bb never
        exceeds P_max, which bounds the gain (loop stability:
        :class:`DefaultParams`). It plays the role of VQF's bias forgetting time
        (sec. 3.3): the warm-up drift keeps changing what was learned.
        """
        s, p = self._state, self.params
        a = dt / p.bias_forget_t
        if a > 1.0:
            a = 1.0
        c, m = 1.0 - a, a / p.bias_tau_min
        xx, xy, xz, yy, yz, zz = s.bias_p
        s.bias_p = (c * xx + m, c * xy, c * xz, c * yy + m, c * yz, c * zz + m)
        s.cross_p = (c * s.cross_p[0], c * s.cross_p[1], c * s.cross_p[2], c * s.cross_p[3], c * s.cross_p[4],
                     c * s.cross_p[5], c * s.cross_p[6], c * s.cross_p[7], c * s.cross_p[8])

    def reference_taken(self) -> None:
        """The heading was just taken as a reference (the game's wearing calibration takes
        "forward" from it): from now on what a field not yet checked settles is taught
        provisionally, as a field on probation teaches (:meth:`_settle_heading`)."""
        self._state.referenced = True

    @property
    def provisional_heading(self) -> float:
        """The share of :attr:`heading` (rad) that a field not yet trusted turned and would
        give back if it were found bad (:meth:`_remember_field`)."""
        return self._state.taught_heading

    @property
    def taken_back(self) -> int:
        """How many times what a field not yet trusted had taught was taken back."""
        return self._state.taken_back

    def power_on(self, age_s: float, warmup_calibrated: bool = False) -> None:
        """The board powered up ``age_s`` seconds ago (its own clock): its warm-up drift is least
        known now, so the drift starts uncertain rather than known to be zero.
        ``warmup_calibrated``: a thermal calibration corrects the readings (:mod:`tracker.thermal`),
        leaving the share of the warm-up that differs from one warming to the next: then the
        drift is learned only once the start has settled (:meth:`_learn_bias_in_motion`).

        The warm-up is a first-order thermal step (:meth:`_drift_bias`): the bias's rate
        of change is largest at power-on and decays as exp(-t / ``drift_tau``), its
        variance as exp(-2 t / ``drift_tau``). At power-on the drift's covariance is
        that of the steady-state two-state loop at the fastest bandwidth the bias may
        follow, 1 / ``bias_tau_min``: for a double integrator with process noise q
        (measurement noise 1) the Riccati equation gives P_dd = sqrt(2) q^(3/4), and
        q = 1 / T^4 gives natural frequency 1 / T (Zarchan and Musoff, sec. 4), so
        P_dd = sqrt(2) / T^3. The loop then slows toward ``drift_t`` as it learns.
        Added to the diagonal, so the covariance stays one whenever this is called.
        A board that has been on for some thermal time constants gets almost nothing, and
        a filter not told (a recording, ``armtracker fuse``) starts with the drift known to
        be zero: given this prior at their start, BROAD's recordings of boards that were
        not just switched on teach the drift noise (9D mean total error 1.52 deg against
        VQF's 1.26; 1.23 without).
        """
        s, p = self._state, self.params
        s.warmup_calibrated = warmup_calibrated
        d = math.sqrt(2.0) / p.bias_tau_min ** 3 * math.exp(-2.0 * max(0.0, age_s) / p.drift_tau)
        xx, xy, xz, yy, yz, zz = s.drift_p
        s.drift_p = (xx + d, xy, xz, yy + d, yz, zz + d)

    def _drift_bias(self, dt: float) -> None:
        """The Kalman prediction of the drift state: the bias moves on by the drift, which
        fades as the board's temperature settles and may change (a random walk).

        The warm-up after power-on is a first-order thermal step, so the bias
        follows b(t) = b_inf - c exp(-t / tau): its rate decays with the thermal
        time constant ``drift_tau``. With F = [[I, dt I], [0, a I]], a = 1 - dt /
        drift_tau: b <- b + dt d, d <- a d; P_bb <- P_bb + dt (P_bd + P_bd') +
        dt^2 P_dd, P_bd <- a (P_bd + dt P_dd), P_dd <- a^2 P_dd + q dt I (any Kalman
        text; Zarchan and Musoff sec. 4). Where gravity observes a bias direction
        only now and then (the axis that is mostly vertical in play), a bias
        loop without this state lags a ramp, and the lag becomes heading drift.
        """
        s, p = self._state, self.params
        a, q = 1.0 - dt / p.drift_tau, dt / p.drift_t ** 4
        if a < 0.0:
            a = 0.0  # a gap longer than drift_tau: the drift has faded (and stays within drift_max)
        dx, dy, dz = s.drift
        b = s.bias
        s.bias = self._clamp(b[0] + dx * dt, b[1] + dy * dt, b[2] + dz * dt)
        s.drift = (dx * a, dy * a, dz * a)
        xx, xy, xz, yy, yz, zz = s.drift_p
        c0, c1, c2, c3, c4, c5, c6, c7, c8 = s.cross_p
        bxx, bxy, bxz, byy, byz, bzz = s.bias_p
        h = dt * dt
        s.bias_p = (bxx + dt * 2.0 * c0 + h * xx, bxy + dt * (c1 + c3) + h * xy, bxz + dt * (c2 + c6) + h * xz,
                    byy + dt * 2.0 * c4 + h * yy, byz + dt * (c5 + c7) + h * yz, bzz + dt * 2.0 * c8 + h * zz)
        s.cross_p = (a * (c0 + dt * xx), a * (c1 + dt * xy), a * (c2 + dt * xz),
                     a * (c3 + dt * xy), a * (c4 + dt * yy), a * (c5 + dt * yz),
                     a * (c6 + dt * xz), a * (c7 + dt * yz), a * (c8 + dt * zz))
        a2 = a * a
        s.drift_p = (a2 * xx + q, a2 * xy, a2 * xz, a2 * yy + q, a2 * yz, a2 * zz + q)

    def _observe_bias(self, h: Vec, innovation: float, r: float, drift: bool = True) -> None:
        """One scalar Kalman update of the bias: the measurement h . b, ``innovation`` its
        measured minus predicted value (rad/s), ``r`` its noise in the units of ``bias_p``.

        K = P h / (h' P h + r);  b <- b + K innovation;  P <- P - K (P h)'
        (any Kalman filter text; VQF sec. 3.3 uses the same update), here over the
        state (bias, drift) with h = (h, 0): the drift moves by P_db h / (h' P_bb h + r).
        ``drift`` False leaves the drift and its covariance as they are (a gain of 0 for
        it; the Joseph form then gives the same P_bb and P_bd): at rest the bias is seen
        directly through the rest test's low-pass, whose lag would teach a drift
        while a bias that starts unknown is found; the magnetometer sees the heading
        itself while it is trusted, and a field not yet found bad must leave nothing
        behind that outlasts its switching off.
        """
        s = self._state
        xx, xy, xz, yy, yz, zz = s.bias_p
        hx, hy, hz = h
        px, py, pz = self._bias_ph(h)
        c0, c1, c2, c3, c4, c5, c6, c7, c8 = s.cross_p  # P_db h = P_bd' h: how the drift covaries
        qx, qy, qz = c0 * hx + c3 * hy + c6 * hz, c1 * hx + c4 * hy + c7 * hz, c2 * hx + c5 * hy + c8 * hz
        scale = 1.0 / (hx * px + hy * py + hz * pz + r)
        kx, ky, kz = px * scale, py * scale, pz * scale
        jx, jy, jz = qx * scale, qy * scale, qz * scale  # the drift's gain
        s.bias_p = (xx - kx * px, xy - kx * py, xz - kx * pz, yy - ky * py, yz - ky * pz, zz - kz * pz)
        s.cross_p = (c0 - kx * qx, c1 - kx * qy, c2 - kx * qz, c3 - ky * qx, c4 - ky * qy, c5 - ky * qz,
                     c6 - kz * qx, c7 - kz * qy, c8 - kz * qz)
        b = s.bias
        s.bias = self._clamp(b[0] + kx * innovation, b[1] + ky * innovation, b[2] + kz * innovation)
        if not drift:
            return
        dxx, dxy, dxz, dyy, dyz, dzz = s.drift_p
        s.drift_p = (dxx - jx * qx, dxy - jx * qy, dxz - jx * qz, dyy - jy * qy, dyz - jy * qz, dzz - jz * qz)
        d, m = s.drift, self.params.drift_max
        dx, dy, dz = d[0] + jx * innovation, d[1] + jy * innovation, d[2] + jz * innovation
        s.drift = _limit(dx, dy, dz, m)

    def _bias_ph(self, h: Vec) -> Vec:
        """P h, P the bias's covariance: h' P h is the variance it adds to the measurement h . b."""
        xx, xy, xz, yy, yz, zz = self._state.bias_p
        hx, hy, hz = h
        return xx * hx + xy * hy + xz * hz, xy * hx + yy * hy + yz * hz, xz * hx + yz * hy + zz * hz

    def _clamp(self, x: float, y: float, z: float) -> Vec:
        """The bias (x, y, z) limited to +-bias_max per axis."""
        return _limit(x, y, z, self.params.bias_max)

    # ------------------------------------------------------------ inclination

    def _correct_inclination(self, acc: Vec, w: Vec, dt: float) -> tuple[float, float] | None:
        """Turn q_inc so the low-passed accelerometer points up; the turn's (x, y) rotation vector.

        ``w``: the bias-corrected rate (rad/s, sensor frame), which ends the start-up's
        mean (:class:`StartMean`). ``dt``: the time since the last sample (several periods
        after lost ones, which the low-pass takes as this sample held: :meth:`LowPass2.step`).
        None while there is no gravity yet.
        """
        s = self._state
        # The sample's specific force, turned into I by the orientation of its own instant. Step 1 turns
        # q_gyr by each sample's rate over the whole interval before it (the rectangle rule), and the sum
        # of the rates since a start at rest runs w dt / 2 ahead of their integral: q_gyr is the
        # orientation half a step on, q(t + dt/2) ~ q(t) exp(w dt/2), and so is the output (its heading
        # always was). R(t) f = R(t + dt/2) (f - dt/2 w x f) to first order. Turned by the orientation
        # half a step on instead, gravity leaned by dt/2 w x f: the inclination took a steady turn's lean
        # back, a tilt half a step behind the heading, and a fast snap with a slow return (every launch)
        # left a mean lean along the snap that the bias loop read as a bias, which walked the heading
        # (README, "A step taken for a ramp": 5-10 degrees in 90 s for the fastest simulated players).
        # A reading the sensor's low-pass delays less than the rates (acc_lead_s) is that much more recent;
        # led by gyro_lead_s (_led), the strapdown is that much more recent than the rates.
        h = 0.5 * dt - self.params.acc_lead_s + self.params.gyro_lead_s
        c = cross(w, acc)
        a_i = rotate(s.q_gyr, (acc[0] - h * c[0], acc[1] - h * c[1], acc[2] - h * c[2]))
        if s.t <= self.params.startup_t:  # fast start: the plain mean, ended where the board's swing is undone
            a_i = s.start.add(a_i, rotate(s.q_gyr, w), s.t, self.params.startup_t)
        else:
            if not s.acc_lp.primed:
                g = s.start.gravity
                if g is not None:
                    s.acc_lp.step(g, dt)  # the low-pass starts settled at the start-up's gravity (StartMean)
            a_i = s.acc_lp.step(a_i, dt)
        ax, ay, az = rotate(s.q_inc, a_i)
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if n < 1e-6:
            return None  # no gravity yet
        # The rotation taking the filtered direction to vertical: about (ay, -ax, 0) by
        # acos(az / n) (computed as atan2(|a_xy|, a_z), the same angle; a half-turn
        # about east when it points straight down).
        rx, ry, _ = tilt_to_up((ax, ay, az))
        s.q_inc = normalize(mul(from_rotvec(rx, ry, 0.0), s.q_inc))
        return rx, ry

    def _learn_bias_in_motion(self, cx: float, cy: float, w: Vec | None, dt: float, drift: bool) -> None:
        """The bias from the inclination correction rate (VQF sec. 3.3 "motion bias
        estimation"; Mahony eq. 32 is the same idea as a fixed integral gain), and
        with ``drift`` its rate of change.

        A bias error e turns the strapdown frame I by R_IS e per second. The
        accelerometer's low-pass in I (:meth:`_correct_inclination`) passes that
        drift on through the same low-pass, so the correction rate in E is
        c = -P R_EI LP(R_IS (b - b_est)), with P keeping x and y (only the
        horizontal part is observable from gravity). So z = P R_EI LP(R_IS b_est) - c
        measures P R_EI LP(R_IS) b: two scalar measurements of the bias, rows
        H = P R_EI LP(R_IS). Low-passing the prediction as the correction was
        (as VQF does) keeps the estimate from chasing the low-pass's delay. As
        the arm turns, every sensor axis takes its turn at being horizontal.

        Turns make the measurement noisier, as independent noises add their
        variances: r = (1 + |w_1|^2 / ``bias_turn_rate``^2 + |w_3|^2 /
        ``bias_turned_rate``^2) / dt. While the arm turns at w (w_1, the rate
        low-passed over ``rest_lp_tau``), a gyroscope sensitivity error s reads
        as a bias of s w. After a turn by theta, the sensitivity matrix's residual
        (0.1-0.2 % after the maker's calibration: README, maker table) has tilted
        the strapdown frame by about s theta, which the accelerometer's low-pass
        takes out over ``tau_acc`` after the turn has ended, as a correction rate
        of about s theta / tau_acc: read as a bias, it is learned along the axes
        that are horizontal then, and whichever of them is vertical in the next
        pose turns the heading while the arm stays there. Every raise of the arm
        leaves one, always of the same sign for the same move, so over a session
        they add up. (Traced on the typical player without a field, seeds 0, 2
        and 3 of 20-minute sessions, scratch: a late aim of 3.3, 3.7 and 3.1
        degrees, almost all of it heading; 1.3, 2.7 and 0.6 with the board's true
        calibration instead of the maker's; 1.1, 5.5 and 1.7 with the true one's
        gyroscope matrix off by a random 0.1 % per entry.) w_3, the rate
        low-passed as the accelerometer is (over ``tau_acc``), is that turn
        divided by ``tau_acc`` for as long as its tilt is being taken out; the
        same sensitivity error makes both, so both rates are the same. (0.1 rad/s
        for ``bias_turned_rate`` held the typical player's heading better still, but
        slowed the bias's convergence in play from 5 deg/s off: 0.30 deg/s left
        after 120 s of unbroken motion instead of 0.10; at 0.25, 0.14.)

        The residual itself is a second Kalman state beside the bias
        (:mod:`tracker.fusion.sensitivity`): the same innovation teaches both, each
        with the other's uncertainty as added noise, so once D explains the tilts
        the turns leave the bias no longer takes them (the heading's walk over
        300 s of raises with a 0.2 % residual: 4.3-5.2 degrees without it,
        0.5-0.9 with it; the tests). ``w`` is the corrected rate's mean over the ``dt``
        of the update (its regressors are stepped at the bias's rate), None where the
        residual is not learned (``sens_prior`` 0).

        ``drift`` False (on a board whose warm-up is calibrated, the first
        ``drift_settle_t`` after the start: :meth:`power_on`) leaves the drift alone. The
        bias the start gave (the start-up hold's, or none) is off by some amount, a step
        the loop takes out in its first seconds, and a two-state loop takes part of a step
        for a ramp while its response lasts; the ramp it learns outlives the step by
        ``drift_tau`` and, about the vertical, turns the heading for minutes. Fast, swaying
        simulated players, whose holds leave the larger steps, lost their heading so
        without a field (README, "A step taken for a ramp"). What a calibration leaves of a
        warm-up ramps slowly enough for the bias alone to follow meanwhile; an uncalibrated
        board's warm-up is steepest just then, and its drift is learned from the start
        (a 4 deg/s warm-up learned 20 s late costs a fast mover's heading 2.6 degrees in
        150 s instead of 1.4: the robustness tests).
        """
        s = self._state
        qw, x, y, z = s.q_gyr  # R_IS, by rows
        rows = ((1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - qw * z), 2.0 * (x * z + qw * y)),
                (2.0 * (x * y + qw * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - qw * x)),
                (2.0 * (x * z - qw * y), 2.0 * (y * z + qw * x), 1.0 - 2.0 * (x * x + y * y)))
        m0, m1, m2 = s.bias_lp_r0.step(rows[0], dt), s.bias_lp_r1.step(rows[1], dt), s.bias_lp_r2.step(rows[2], dt)
        pb = s.bias_lp_rb.step(rotate(s.q_gyr, s.bias), dt)
        if w is not None:
            s.sens.regress(rows, w, dt)
        qw, x, y, z = s.q_inc  # rows 1 and 2 of R_EI
        e0 = (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - qw * z), 2.0 * (x * z + qw * y))
        e1 = (2.0 * (x * y + qw * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - qw * x))
        # The measurement's noise: 1 / dt is the unit of bias_p; turns add to it, now and just past.
        p = self.params
        gx, gy, gz = s.rest_gyr.y
        bx, by, bz = s.bias
        rate2 = (gx - bx) ** 2 + (gy - by) ** 2 + (gz - bz) ** 2
        turn = rate2 / (p.bias_turn_rate * p.bias_turn_rate)
        tx, ty, tz = s.turned_lp.y
        turned = (tx * tx + ty * ty + tz * tz) / (p.bias_turned_rate * p.bias_turned_rate)
        r = (1.0 + turn + turned) / dt
        for a, c in ((e0, cx), (e1, cy)):
            a0, a1, a2 = a
            h = (a0 * m0[0] + a1 * m1[0] + a2 * m2[0], a0 * m0[1] + a1 * m1[1] + a2 * m2[1],
                 a0 * m0[2] + a1 * m1[2] + a2 * m2[2])
            b = s.bias
            innovation = a0 * pb[0] + a1 * pb[1] + a2 * pb[2] - c - (h[0] * b[0] + h[1] * b[1] + h[2] * b[2])
            # The residual sensitivity takes its share of the same innovation once the arm has stopped,
            # after the start (tracker.fusion.sensitivity); each sees the other's uncertainty as noise.
            spread = 0.0
            if w is not None:
                ph, spread = s.sens.row(a)
                if rate2 < p.sens_still_rate * p.sens_still_rate and s.t > p.sens_start_t:
                    px, py, pz = self._bias_ph(h)
                    s.sens.learn(ph, spread, innovation, r + h[0] * px + h[1] * py + h[2] * pz)
            self._observe_bias(h, innovation, r + spread, drift)

    # ------------------------------------------------------------ heading

    def _correct_heading(self, q6: Quat, mag: Vec, dt: float) -> None:
        s, p = self._state, self.params
        mx, my, mz = rotate(q6, mag)
        norm = math.sqrt(mx * mx + my * my + mz * mz)
        if norm < 1e-6:
            return
        dip = math.asin(max(-1.0, min(1.0, mz / norm)))
        # The horizontal field points atan2(mx, my) east of north (+y) in the 6D frame;
        # turning about +z by that angle brings it back to north.
        err = (math.atan2(mx, my) - s.heading + math.pi) % (2 * math.pi) - math.pi
        self._judge_field(q6, norm, dip, dt)
        weight = self._heading_weight(err, dt)
        if s.mag_reason or not self._field_undisturbed(norm, dip, dt):
            self.flags.mag_rejected = True
            return
        # On probation (its first mag_on_t of use) the field turns the heading more slowly, and
        # a field whose heading spreads as the board moves turns it more slowly still.
        k = dt * weight / (p.tau_mag if s.mag_use_t > p.mag_on_t else p.tau_mag_probation)
        if s.t <= p.startup_t:
            k = max(k, 1.0 / s.mag_samples)  # fast start: plain average of the first second
        elif not s.mag_checked:
            k = self._settle_heading(weight, err, dt)
            if s.referenced:
                s.taught_heading += k * err
        else:
            b = s.bias
            self._learn_bias_from_heading(q6, k * err / dt, weight, dt)
            self._remember_field(k * err, (s.bias[0] - b[0], s.bias[1] - b[1], s.bias[2] - b[2]), dt)
        s.heading = (s.heading + k * err + math.pi) % (2 * math.pi) - math.pi

    def _settle_heading(self, weight: float, err: float, dt: float) -> float:
        """The heading's gain until the field's first check (of a field never found bad), ``weight``
        its heading's (:meth:`_heading_weight`).

        The first second's average set the heading in a 6D frame whose
        inclination was the start's mean of the accelerometer, which carries what
        a tremor's acceleration did not average out; a tilt turns the field's
        vertical part into its heading (by the dip's tangent). So until its check
        the field keeps the heading in step with the inclination as that settles
        over ``tau_acc``, weighed by its heading's spread, and the heading has
        settled before the game's wearing calibration rather than turning after
        it. A field whose heading spreads beyond ``mag_weak_sd`` (or found bad)
        settles nothing meanwhile. What it settled before the heading was taken as
        a reference stays, since taking it back would turn the heading after a
        wearing calibration that saw it; what it settles after (:meth:`reference_taken`)
        is provisional, as a field on probation teaches, and taken back if the field
        is found bad before it is trusted (:meth:`_remember_field`). Between the
        calibration and the check a clean field holds the heading against a bias
        the start-up hold knew only to its bound, and one that varies with position
        turns it toward the places the arm has been (the magnetic room's seed 5:
        -2.3 degrees in 30 s, then found bad); the filter cannot tell the two apart
        until the check, so it keeps the first and gives back the second
        (docs/gesture-accuracy-log.md, "A field still being checked"). Nothing is
        taught to the bias.
        """
        s, p = self._state, self.params
        self.flags.mag_rejected = True  # (its check is still to come: not in use)
        return 0.0 if self.heading_spread > p.mag_weak_sd else dt * weight / p.tau_acc

    def _remember_field(self, turn: float, db: Vec, dt: float) -> None:
        """What a field taught (heading turn, bias change) in its first ``mag_trust_t`` of use:
        if it is found bad meanwhile, all it taught is taken back (:meth:`_take_back_field`),
        so a bad field that once looked consistent leaves the pose no worse than no
        magnetometer would have. (Afterwards a field teaches only as fast as its heading's
        spread allows: :meth:`_heading_weight`.)

        ``mag_trust_t`` is twice the check, ``mag_on_t``: a field the check let through
        in a room whose disturbance varies with position was consistent only where the
        arm had been, and is found bad once the arm has gone elsewhere. Traced on the
        magnetic room (one ten-minute session, scratch), each field found bad had been
        in use for 20-29 s, and what it had turned after its first 15 s stayed in the
        heading (-1.3 degrees in all), so over ten minutes 9D's late aim was 0.76
        degrees against 6D's 0.56 (README, "The magnetometer against none"). Fields that
        held a fast player's walking heading in a disturbed room stayed in use for 150-207 s
        before they were found bad: taking back all a field ever taught lost that (their
        late aim 3.30 -> 4.09 degrees, 3.66 -> 4.49 over four sessions of two players),
        while twice the check cost them 0.00 and 0.08 degrees (docs/gesture-accuracy-log.md,
        "What a field found bad had taught")."""
        s = self._state
        s.mag_use_t += dt
        if s.mag_use_t > self.params.mag_trust_t:  # proved itself: what it teaches is kept
            s.taught_heading, s.taught_bias = 0.0, (0.0, 0.0, 0.0)
            return
        (x, y, z) = s.taught_bias
        s.taught_heading += turn
        s.taught_bias = (x + db[0], y + db[1], z + db[2])

    def _take_back_field(self) -> None:
        """A field found bad before it was trusted (within ``mag_trust_t`` of use, or while
        still being checked after the reference): what it taught is taken back
        (:meth:`_remember_field`, :meth:`_settle_heading`).
        The bias's drift is left as it is: the field never teaches it (:meth:`_observe_bias`), and
        what the inclination taught it meanwhile is the gyroscope's own (a warming board's)."""
        s = self._state
        (x, y, z), b = s.taught_bias, s.bias
        if s.taught_heading == 0.0 and x == y == z == 0.0:
            return  # nothing taught (a field found bad again while off, or trusted before)
        s.bias = self._clamp(b[0] - x, b[1] - y, b[2] - z)
        s.heading = (s.heading - s.taught_heading + math.pi) % (2 * math.pi) - math.pi
        s.taught_heading, s.taught_bias = 0.0, (0.0, 0.0, 0.0)
        s.taken_back += 1

    def _learn_bias_from_heading(self, q6: Quat, c: float, weight: float, dt: float) -> None:
        """The bias about the vertical from the heading correction rate ``c`` (rad/s): the
        magnetometer's share of Mahony's integral term (eq. 32), which gravity cannot give.

        A bias error e turns the heading at (R_WS e)_z per second; the correction
        turns it back, so c measures -h . e with h = R_WS^T z, world z in the sensor
        frame. The heading follows the field with time constant ``tau_mag``, so this
        measurement counts ``tau_mag / bias_tau_min`` times less than the
        inclination's: with the Kalman gain bounded by 1 / bias_tau_min, the loop of
        heading and bias is then damped (zeta about 0.5). A field whose heading
        spreads counts ``weight`` times less again (:meth:`_heading_weight`).
        """
        p = self.params
        w, x, y, z = q6
        h = (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y))
        self._observe_bias(h, -c, p.tau_mag / p.bias_tau_min / weight / dt, drift=False)

    def _heading_weight(self, err: float, dt: float) -> float:
        """How much the field's heading may count, from how its heading innovation ``err``
        (the field's heading in the 6D frame minus the filter's, rad) spreads as the board moves.

        The Earth's field has one direction wherever the board points, so the
        innovation moves only as slowly as the gyroscope's heading drifts. A
        disturbance that varies with position turns the field's direction as the
        arm moves, also where its strength and dip stay the same (what
        :meth:`_judge_field` sees); the innovation then wanders with the arm's
        pose. Low-passed over ``mag_head_lp_tau`` (which averages the
        magnetometer's white noise, harmless to a correction over ``tau_mag``)
        and taken as a unit vector (no wrap at +-pi), its spread over the window
        ``mag_window_t`` is 2 (1 - R), R the length of the window's mean vector
        (circular statistics: K. V. Mardia and P. E. Jupp, "Directional
        Statistics", 2000, sec. 2.3.1; about the variance for small spreads).
        Taken as the measurement's noise, it scales the gain as a steady-state
        Kalman filter's: for a heading that drifts as a random walk of density q,
        measured with noise of density R, the scalar Riccati equation
        0 = q - P^2 / R gives P = sqrt(q R) and the gain P / R = sqrt(q / R)
        (the Kalman-Bucy filter), which goes as 1 / spread: 1 up to
        ``mag_head_sd``, mag_head_sd / spread beyond, never 0 (the spread is at
        most sqrt(2)). (x-io Fusion rejects a field whose
        heading innovation is large; this weighs it instead.)

        A field that passed its check (:meth:`_judge_field`: consistent for
        ``mag_on_t`` while the board turned) and was found bad afterwards n
        times counts 1 / (1 + n) as much, its noise's spread taken as n + 1 times
        what the window shows. Each refutation says the window's spread
        understates the noise: the field was consistent where the arm had just
        been and not where it went, so the heading it gives at one place differs
        from another's by more than any window there shows. Such a room (a
        disturbance of 17-40 uT that varies with position, beside a horizontal
        field of 20 uT) turned a fast player's heading after the wearing
        calibration toward its own heading at the places the arm then went,
        making the late aim up to 3.7 degrees worse than with the gyroscope
        alone (README, "Open (issue 12)"). As refutations add up the heading becomes the
        gyroscope's, as without a magnetometer, while a field never found bad
        after its check counts as before, bit for bit.
        """
        s, p = self._state, self.params
        if s.t <= p.startup_t:
            return 1.0  # the start-up's plain average of the heading
        first = not s.head_lp.primed
        c, sn, _ = s.head_lp.step((math.cos(err), math.sin(err), 0.0), dt)
        n = math.sqrt(c * c + sn * sn)
        if n > 1e-9:  # (a low-passed unit vector of length 0: no direction to add)
            c, sn = c / n, sn / n
            hx, hy = (c, sn) if first else s.win_head
            a = dt / p.mag_window_t
            if a > 1.0:
                a = 1.0
            s.win_head = (hx + a * (c - hx), hy + a * (sn - hy))
        return self.field_weight

    def _field_undisturbed(self, norm: float, dip: float, dt: float) -> bool:
        """Magnetic disturbance test on the field's norm and dip angle (VQF sec. 3.4)."""
        s, p = self._state, self.params
        s.mag_samples += 1
        if s.mag_norm == 0.0 or s.t <= p.startup_t:
            n = s.mag_samples
            s.mag_norm += (norm - s.mag_norm) / n
            s.mag_dip += (dip - s.mag_dip) / n
            return True
        ok = abs(norm - s.mag_norm) < p.mag_norm_th * s.mag_norm and abs(dip - s.mag_dip) < p.mag_dip_th
        if ok:
            k = dt / p.mag_ref_tau
            s.mag_norm += k * (norm - s.mag_norm)
            s.mag_dip += k * (dip - s.mag_dip)
        return ok

    def _judge_field(self, q6: Quat, norm: float, dip: float, dt: float) -> None:
        """Is the field consistent? Its norm and dip over a window, while the board turns.

        The Earth's field has one norm and one dip wherever the board points
        (VQF sec. 3.4's premise). A hard-iron offset h adds R h, a soft-iron
        distortion E adds E m: both change the norm and dip as the board turns,
        as does a disturbance that varies with position. Exponentially weighted
        means and variances over ``mag_window_t`` (D. Finch, "Incremental
        calculation of weighted mean and variance", 2009, sec. 9) give their
        spread; a spread beyond the thresholds switches the field off. It is
        switched on again after ``mag_on_t`` seconds of a consistent field while
        the board turned (the spread of world y and z seen from the sensor over
        the window, 2 - |mean y|^2 - |mean z|^2, beyond ``mag_turn_th``): a board
        held still shows any field as consistent.
        """
        s, p = self._state, self.params
        if s.t <= p.startup_t:
            return  # the inclination is still settling: its dip would read as spread
        w, x, y, z = q6
        wy = (2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x))  # row 2 of R
        wz = (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y))  # row 3 of R
        if s.mag_t == 0.0:
            s.win_norm, s.win_dip, s.win_y, s.win_z = norm, dip, wy, wz
        s.mag_t += dt
        a = dt / p.mag_window_t
        if a > 1.0:
            a = 1.0
        dn, dd = norm - s.win_norm, dip - s.win_dip
        s.win_norm += a * dn
        s.win_dip += a * dd
        s.win_norm_var = (1.0 - a) * (s.win_norm_var + a * dn * dn)
        s.win_dip_var = (1.0 - a) * (s.win_dip_var + a * dd * dd)
        (y0, y1, y2), (z0, z1, z2) = s.win_y, s.win_z
        s.win_y = (y0 + a * (wy[0] - y0), y1 + a * (wy[1] - y1), y2 + a * (wy[2] - y2))
        s.win_z = (z0 + a * (wz[0] - z0), z1 + a * (wz[1] - z1), z2 + a * (wz[2] - z2))
        if s.mag_t < p.mag_judge_t:
            return  # too little seen yet (a part-filled window's variance reads low: no false alarm)
        th_norm = p.mag_norm_sd_th * s.win_norm
        reason = (MAG_STRENGTH if s.win_norm_var > th_norm * th_norm else
                  MAG_DIP if s.win_dip_var > p.mag_dip_sd_th * p.mag_dip_sd_th else "")
        if reason:
            if s.mag_checked:  # found bad after its check: the check was refuted
                s.mag_refuted += 1
            self._take_back_field()  # what it taught before it was trusted (nothing once trusted)
            s.mag_reason, s.mag_good_t, s.mag_checked = reason, 0.0, False
        elif not s.mag_checked:
            (y0, y1, y2), (z0, z1, z2) = s.win_y, s.win_z
            turned = 2.0 - (y0 * y0 + y1 * y1 + y2 * y2) - (z0 * z0 + z1 * z1 + z2 * z2)
            # One unbroken spell of turning (the first check, of a field never found bad, needs none).
            s.mag_good_t = s.mag_good_t + dt if turned > p.mag_turn_th or not s.mag_reason else 0.0
            if s.mag_good_t >= p.mag_on_t:  # consistent long enough while turning: used, the window its reference
                s.mag_reason, s.mag_good_t, s.mag_checked, s.mag_use_t = "", 0.0, True, 0.0
                s.mag_norm, s.mag_dip = s.win_norm, s.win_dip


FILTER_CLASS = DefaultFilter


def for_mpu9250(rate_hz: float, at_shoulder: bool = False) -> DefaultFilter:
    """The default filter for an MPU-9250 streaming at ``rate_hz``: told how much more recently its
    accelerometer reads than its gyroscope at the firmware's low-pass setting (``acc_lead_s``,
    :class:`tracker.mpu_dlpf.Dlpf`), and how far to lead the rates to undo that low-pass's
    attenuation of a tremor (``gyro_lead_s``, :meth:`tracker.mpu_dlpf.Response.amplitude_lead_s`).
    ``at_shoulder``: its accelerometer is moved to the
    shoulder (:mod:`tracker.lever_arm`), so the gyroscope's residual sensitivity is learned
    (:mod:`tracker.fusion.sensitivity`), and the bias loop's turn gates open to
    ``SHOULDER_TURN_RATE``: the tilt a turn leaves, which they keep from being learned as a
    bias, is the residual's to explain there, and a fast player, who turns faster than 0.25
    rad/s most of the time, would teach the bias too little to hold the heading (README,
    "A fast player's bias at the shoulder")."""
    dlpf = Dlpf.for_rate(rate_hz)
    params = DefaultParams(acc_lead_s=dlpf.acc_lead_s, gyro_lead_s=dlpf.gyro.amplitude_lead_s(rate_hz))
    if at_shoulder:
        params = replace(params, sens_prior=SHOULDER_SENS_PRIOR, bias_turn_rate=SHOULDER_TURN_RATE,
                         bias_turned_rate=SHOULDER_TURN_RATE)
    return DefaultFilter(params)
