"""The accelerometer moved to the shoulder: an upper-arm board's lever-arm accelerations taken off.

A board on the upper arm sits some 0.2-0.35 m from the shoulder, the point the
arm turns about. Turning at w with angular acceleration w', the board feels,
besides gravity and whatever moves the shoulder, the centripetal and
tangential accelerations of that lever arm. With o the shoulder's position
seen from the board (sensor frame), the specific force at the shoulder is

    a_o = a + w x (w x o) + w' x o = a + K o,   K = [w]x^2 + [w']x

(the rigid-body relation every IMU text gives; T. Seel, J. Raisch and T.
Schauer, "IMU-based joint angle measurement for gait analysis", Sensors
14(4), 2014, sec. 2.2, shift accelerations to a joint centre just so). The
centripetal part w x (w x o) points at the shoulder whichever way the arm
turns, so it does not average out: low-passed by the filter as if it were
gravity, it tilts the inclination a degree or more in play, the tilt teaches
the gyroscope's bias a wrong value, and without a magnetometer the bias's
vertical part turns the heading by several degrees over ten minutes (the
README's measurements). At the shoulder only gravity is left (and what the
trunk adds, which is slow or zero-mean), so the filter gets ``a_o``.

``o`` is not measured by anyone: it is fitted as the board is used. The
shoulder moves little, so a_o is about gravity, R_WS^T (0, 0, g), whose
direction the filter knows; then a - R^T g = -K o is linear in o, and o is
the least-squares solution over the last ``window_t`` seconds (Seel et al.
2014 fit joint positions from the same relation, there between two
segments). A small ridge keeps o at 0 until the arm has turned enough to show
it, and a fit beyond ``max_m`` is refused.

The fit and the correction see different bands, on purpose. The fit takes
rates and the accelerometer less gravity low-passed alike (``tau``, cut-off
about 4 Hz; a linear relation low-passed on both sides still holds, and
gravity is taken off before, since it turns with the board): it learns o from the
arm's moves, not from the board rocking on the soft tissue at 5-25 Hz, which
turns it about a pivot of its own a centimetre or two under the strap and
would pull o toward that. The correction takes the rates as measured: a
tremor turns the humerus about the shoulder at up to 12 Hz, and a low-passed
correction would lag it and add error rather than take it off (a fast, shaky
simulated player's two-minute median aim went from 2.0 deg without the
correction to 3.9 with a low-passed one: README, "The accelerometer at the
shoulder").

The rocking's own accelerations are then corrected with the shoulder's lever,
wrongly, some tens of m/s^2 each sample; what must hold is that they average
out in the filter's 3 s low-pass, and that decides how K o is sampled. The
filter low-passes the readings turned into its frame I, and in any frame,
turned so, K o is the second derivative of the turned offset,
R K o = d^2/dt^2 (R o), whose mean over a bounded rocking is nothing. The
correction is therefore K o's mean over the sample's interval, taken from
that identity rather than from a w' at an instant: (R o)' = R (w x o), so

    mean K o = R_k^T (R_k (w_k x o) - R_k-1 (w_k-1 x o)) / dt
             = (w_k x o - R_step^T (w_k-1 x o)) / dt,

R_step the turn over the interval by the sample's rate, the same step the
filter integrates (DefaultFilter, step 1), so its sum over any stretch,
turned into frame I, is exactly the change of R (w x o) between its ends.
(A w' at each instant, the three-point backward difference exact for a
quadratic, B. Fornberg, Math. Comp. 51(184), 1988, reads a 23.5 Hz rocking at
200 Hz 15 % too large, (3 - 4 z + z^2) / (2 h) against i w with
z = exp(-i w h); its product with the rocking's own turn averaged 2 m/s^2
in frame I through a strap's 5 deg rocking at 23.5 Hz, a lean the bias loop
learns: README, "The strap's rocking, sampled".) The filter turns a reading by its
frame half a step before the sample less the accelerometer's lead over the
gyroscope (``acc_lead_s``; DefaultFilter._correct_inclination); the mean is
given in the frame of the interval's end, so it is turned back by that much,
(I + h [w]x) to first order with h = dt / 2 - acc_lead_s, for the filter to
turn it by R_k.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mypy_extensions import mypyc_attr

from .fusion.qmath import cross, from_rotvec, rotate_inverse
from .lowpass import LowPass2

Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Mat3 = tuple[float, float, float, float, float, float, float, float, float]  # by rows
GRAVITY = 9.81
UP_G = (0.0, 0.0, GRAVITY)
EVERY = 4  # samples per update of the fit's sums (its signals are low-passed to about 4 Hz first)


@dataclass(frozen=True)
class LeverArmParams:
    """Settings of the lever-arm fit (seconds, metres)."""

    tau: float = 0.056  # low-pass time constant of rates and accelerations: cut-off sqrt(2) / (2 pi tau) = 4 Hz
    window_t: float = 60.0  # the fit's sums forget over about this long (a strap moved, a new wearer)
    solve_t: float = 1.0  # the fit is solved this often
    ridge: float = 0.5  # s^-4: o stays near 0 until K'K's mean over the window is well above this
    max_m: float = 0.6  # a fit farther than this from the board is refused (an arm is shorter)


@mypyc_attr(serializable=True)  # copy.deepcopy works when compiled
@dataclass
class LeverArmState:
    """What the fit has learned (read-only outside)."""

    gyr_lp: LowPass2
    acc_lp: LowPass2  # the accelerometer less gravity, low-passed as the rate is
    rate_lp: Vec | None = None  # the low-passed rate at the last sample (rad/s): the fit's
    rate: Vec | None = None  # the rate at the last sample (rad/s): the correction's
    info: tuple[float, float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # sum K'K: xx xy xz yy yz zz
    rhs: Vec = (0.0, 0.0, 0.0)  # sum -K'(a - g_s)
    offset: Vec = (0.0, 0.0, 0.0)  # o: the shoulder seen from the board, sensor frame (m)
    n: int = 0  # samples since the last update of the sums
    since_solve: float = 0.0  # seconds since the fit was last solved


@dataclass
class LeverArm:
    """Fits the lever arm as the board moves and takes its accelerations off the accelerometer."""

    params: LeverArmParams = field(default_factory=LeverArmParams)
    state: LeverArmState = field(init=False)

    def __post_init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget the fit (a new board or wearer)."""
        tau = self.params.tau
        self.state = LeverArmState(LowPass2(tau), LowPass2(tau))

    @property
    def offset(self) -> Vec:
        """o, the shoulder seen from the board in the sensor frame (m): 0 until fitted."""
        return self.state.offset

    def at_shoulder(self, gyr: Vec, acc: Vec, q: Quat, dt: float, acc_lead_s: float = 0.0) -> Vec:
        """The specific force at the shoulder, a + K o (K o's mean over the sample's interval, module
        docstring), from the calibrated rate ``gyr`` (rad/s) and
        ``acc`` (m/s^2) of one sample; ``q`` the filter's q_WS before it (scalar first), whose
        gravity the fit compares with; ``acc_lead_s`` the filter's own (DefaultParams.acc_lead_s),
        which sets the frame it turns the reading by. A reading that is not finite passes unchanged,
        unlearned."""
        gx, gy, gz = gyr
        ax, ay, az = acc
        if not (-1e6 < gx + gy + gz + ax + ay + az < 1e6) or not 0.0 < dt < 1.0:  # also NaN
            return acc
        s, p = self.state, self.params
        w = s.gyr_lp.step(gyr, dt)
        gx_s, gy_s, gz_s = rotate_inverse(q, UP_G)  # gravity's reaction in the sensor frame, R_WS^T (0, 0, g)
        lever = s.acc_lp.step((ax - gx_s, ay - gy_s, az - gz_s), dt)
        s.n += 1
        if s.n >= EVERY:  # the fit: the arm's moves (module docstring)
            self._learn(_k_matrix(w, _rate_of_change(s.rate_lp, w, s.n * dt)), lever, s.n * dt)
            s.rate_lp, s.n = w, 0
        s.since_solve += dt
        if s.since_solve >= p.solve_t:
            s.since_solve = 0.0
            self._solve()
        k = self._lever_acceleration(gyr, dt, acc_lead_s)  # the correction: every turn of the bone
        return ax + k[0], ay + k[1], az + k[2]

    def _lever_acceleration(self, gyr: Vec, dt: float, acc_lead_s: float) -> Vec:
        """K o's mean over the last sample interval (module docstring), (w x o - R_step^T (w_before x o)) / dt
        in the frame of the interval's end, turned back by h = dt / 2 - ``acc_lead_s`` into the frame
        the filter turns a reading by. With no rate before, the centripetal part alone."""
        s = self.state
        before = s.rate if s.rate is not None else gyr
        s.rate = gyr
        o = s.offset
        v, v_before = cross(gyr, o), cross(before, o)
        vx, vy, vz = rotate_inverse(from_rotvec(gyr[0] * dt, gyr[1] * dt, gyr[2] * dt), v_before)
        mean = ((v[0] - vx) / dt, (v[1] - vy) / dt, (v[2] - vz) / dt)
        h = 0.5 * dt - acc_lead_s
        turn = cross(gyr, mean)
        return (mean[0] + h * turn[0], mean[1] + h * turn[1], mean[2] + h * turn[2])

    def _learn(self, k: Mat3, lever: Vec, dt: float) -> None:
        """Add one row block of the least squares K o = -(a - R^T g) (``lever``: a - R^T g),
        forgetting over ``window_t``."""
        s = self.state
        r0, r1, r2 = -lever[0], -lever[1], -lever[2]
        c = dt / self.params.window_t
        f = 1.0 - c if c < 1.0 else 0.0
        k0, k1, k2, k3, k4, k5, k6, k7, k8 = k
        i = s.info
        s.info = (f * i[0] + c * (k0 * k0 + k3 * k3 + k6 * k6), f * i[1] + c * (k0 * k1 + k3 * k4 + k6 * k7),
                  f * i[2] + c * (k0 * k2 + k3 * k5 + k6 * k8), f * i[3] + c * (k1 * k1 + k4 * k4 + k7 * k7),
                  f * i[4] + c * (k1 * k2 + k4 * k5 + k7 * k8), f * i[5] + c * (k2 * k2 + k5 * k5 + k8 * k8))
        b = s.rhs
        s.rhs = (f * b[0] + c * (k0 * r0 + k3 * r1 + k6 * r2), f * b[1] + c * (k1 * r0 + k4 * r1 + k7 * r2),
                 f * b[2] + c * (k2 * r0 + k5 * r1 + k8 * r2))

    def _solve(self) -> None:
        """o = (K'K + ridge I)^-1 K'r over the window (Cramer's rule); a fit farther than ``max_m`` is
        refused (the last one stays)."""
        p, s = self.params, self.state
        xx, xy, xz, yy, yz, zz = s.info
        xx, yy, zz = xx + p.ridge, yy + p.ridge, zz + p.ridge
        c0, c1, c2 = yy * zz - yz * yz, xz * yz - xy * zz, xy * yz - xz * yy  # cofactors (symmetric)
        c4, c5, c8 = xx * zz - xz * xz, xy * xz - xx * yz, xx * yy - xy * xy
        det = xx * c0 + xy * c1 + xz * c2
        if not det > 0.0:
            return
        b0, b1, b2 = s.rhs
        o = ((c0 * b0 + c1 * b1 + c2 * b2) / det, (c1 * b0 + c4 * b1 + c5 * b2) / det,
             (c2 * b0 + c5 * b1 + c8 * b2) / det)
        if math.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]) <= p.max_m:
            s.offset = o


def _rate_of_change(before: Vec | None, now: Vec, dt: float) -> Vec:
    """w' from two rates ``dt`` apart (0 without one before)."""
    if before is None:
        return (0.0, 0.0, 0.0)
    return ((now[0] - before[0]) / dt, (now[1] - before[1]) / dt, (now[2] - before[2]) / dt)


def _k_matrix(w: Vec, wd: Vec) -> Mat3:
    """K = [w]x^2 + [w']x by rows, so that K o = w x (w x o) + w' x o."""
    x, y, z = w
    a, b, c = wd
    return (-(y * y + z * z), x * y - c, x * z + b,
            x * y + c, -(x * x + z * z), y * z - a,
            x * z - b, y * z + a, -(x * x + y * y))
