"""The papers' simulation experiments, rerun on our simulator and filters.

- :func:`static_drift`: the IMU and infrared hand-tracking paper, sec. 4.1, the
  5-minute static test: three IMUs lying still, each with its own gyroscope bias
  offset, their orientation estimated with the orientation correction (eqs. 2, 5-16)
  disabled and enabled.
- :func:`finger_grasp`: Inertial Sensor Based Solution for Finger Motion Tracking
  (Computers 9(2):40, 2020), sec. 3 and Figure 10: the grasp motion on the
  three-link finger, three series of sensor errors (white noise, zero offset, both),
  32 motion durations, the RMS error of four estimators against duration.

Both return plain dicts ready for ``json.dumps``; :func:`plot_static_drift` and
:func:`plot_finger_grasp` draw them (matplotlib, an optional dependency).
Long runs report their progress through an optional ``progress(message)``.

Conventions (ARCHITECTURE.md): ``q_WS`` maps sensor to world, world z up. On
the finger (:func:`tracker.sim.finger_chain`) every link frame turns about the
world x axis only, so a link's orientation is its flexion angle theta (the finger-tracking paper
, sec. 2.1: the angle between y and y_i, about x). With ``R(theta)`` the
rotation about x, the sensor's y axis points along ``(0, cos theta, sin theta)``
in the world and the specific force at rest reads ``(0, g sin theta, g cos theta)``.
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from . import quat as Q
from . import sim
from .atomic import AtomicFile
from .evaluate import error_angles
from .fusion import make

Array = NDArray[np.float64]
Progress = Callable[[str], None] | None

SERIES = {"noise": (True, False), "bias": (False, True), "both": (True, True)}  # (noise, offset)
ALGORITHMS = ("gravity", "integration", "switching", "hinge")
GRASP_DELAY_S = 0.2  # the finger-tracking paper, sec. 3: t_d
STATIC_BIASES_DPS = (0.05, 0.1, 0.2)
_GRAVMAG_OFF = {"rest_threshold": 0.0, "tau_acc": math.inf, "tau_mag": math.inf}


def _report(progress: Progress, message: str) -> None:
    """Pass a progress message on, if anyone listens."""
    if progress is not None:
        progress(message)


# ------------------------------------------------------------ the hand-tracking paper, sec. 4.1


def _static_simulator(biases_dps: Sequence[float], seed: int) -> sim.Simulator:
    """The hand-tracking paper, sec. 4.1: IMUs "fixed to a table", here lying flat (q_WS = 1), one per bias.

    They carry the MPU-9250's white noise (:func:`tracker.sim.mpu9250`) but no
    random offsets: each gyroscope's offset is the given bias, added by
    :func:`static_drift`, and the accelerometers have none, so the corrected
    estimate is limited by noise alone. The magnetometer is noise-free: the
    test isolates the gyroscopes' drift, and the hand-tracking paper's IMUs (Yost 3-Space)
    are not AK8963s, whose noise the harsh-world figures carry elsewhere.
    """
    chain = sim.Chain((sim.LinkSpec("table", 0.0),),
                      tuple(sim.SensorSpec(f"imu{i}", 0, (0.0, 0.0, 0.0)) for i in range(len(biases_dps))))
    still = sim.Motion(lambda t: Q.identity(np.shape(t)), lambda t: np.zeros((len(t), 0)))
    errors = sim.mpu9250(noise=True, offset=False)
    quiet_mag = dataclasses.replace(errors, mag=dataclasses.replace(errors.mag, noise_density=0.0))
    return sim.Simulator(chain, still, quiet_mag, seed=seed)


def static_drift(minutes: float = 5.0, rate: float = 100.0,
                 biases_dps: Sequence[float] = STATIC_BIASES_DPS, seed: int = 0,
                 progress: Progress = None) -> dict:
    """The hand-tracking paper, sec. 4.1: the orientation error of static IMUs after ``minutes``.

    IMU i's gyroscope reads ``b_i`` deg/s on each of its three axes (a bias
    vector of length ``sqrt(3) b_i``) plus MPU-9250 white noise. Two runs of the
    the hand-tracking paper filter (:mod:`tracker.fusion.gravmag`) per IMU:

    - "off": the correction disabled (Fig. 11) by its parameters: no bias
      estimation at rest (``rest_threshold=0``: no sample counts as rest, so
      eq. 2 never updates the bias) and no gravity or north correction
      (``tau_acc = tau_mag = inf``: eqs. 9 and 14 apply ``Delta q^0 = 1``).
      What is left is the integration of eqs. 3-4 from the filter's start
      (levelled by the first accelerometer sample, heading by the first
      magnetometer sample), so the error grows as ``sqrt(3) b t`` (until it
      wraps at half a turn).
    - "on": the filter as it ships (Fig. 12).

    The hand-tracking paper gives no bias values; the defaults are residual biases of a few
    hundredths of a degree per second. They must stay well under the filter's
    rest threshold (1.5 deg/s, in norm: ``sqrt(3) b`` plus noise), or the
    corrected filter never sees the IMU at rest and cannot estimate the bias.

    The error is the total rotation angle between estimate and truth at the
    last sample (BROAD metric, :func:`tracker.evaluate.error_angles`), in
    degrees; the inclination part (the heading-free part) is reported too.
    """
    n = round(minutes * 60.0 * rate)
    data = _static_simulator(biases_dps, seed).simulate(n / rate, rate)
    imus = []
    for i, bias in enumerate(biases_dps):
        gyr = data.gyr[:, i] + math.radians(bias)
        off, on = (_end_errors(make("gravmag", **params).run(gyr, data.acc[:, i], data.mag[:, i], rate),
                               data.truth.q_sensors[-1, i])
                   for params in (_GRAVMAG_OFF, {}))
        imus.append({"bias_dps": float(bias), "error_deg_off": off[0], "error_deg_on": on[0],
                     "inclination_deg_off": off[1], "inclination_deg_on": on[1]})
        _report(progress, f"static drift: IMU {i + 1}/{len(biases_dps)} (bias {bias:g} deg/s): "
                          f"{off[0]:.2f} deg off, {on[0]:.2f} deg on")
    return {"minutes": n / rate / 60.0, "rate_hz": rate, "imus": imus}


def _end_errors(q_est: Array, q_true: Array) -> tuple[float, float]:
    """Total and inclination error (degrees) of the last estimate (BROAD metric)."""
    total, _, inclination = error_angles(q_est[-1], q_true)
    return math.degrees(float(total)), math.degrees(float(inclination))


# ------------------------------------------------------------ the finger-tracking paper, sec. 3


def paper_errors(noise: bool, offset: bool) -> sim.SensorErrors:
    """The finger-tracking paper, sec. 3's sensor errors: MPU-9250 white noise and/or zero offset, nothing else.

    The paper adds only these two to ideal, calibrated readings, so the
    quantisation and full-scale clipping of :func:`tracker.sim.mpu9250` are
    left out (at t_m = 0.1 s the distal phalanx turns at about 8000 deg/s,
    beyond the chip's 2000 deg/s).
    """
    e = sim.mpu9250(noise=noise, offset=offset)
    ideal = {"resolution": 0.0, "full_scale": math.inf}
    return dataclasses.replace(e, gyr=dataclasses.replace(e.gyr, **ideal),
                               acc=dataclasses.replace(e.acc, **ideal))


def grasp_rate(move_s: float, rate: float, max_rate: float, motion_samples: int) -> float:
    """The sample rate for a grasp of ``move_s`` seconds: ``rate``, raised for short motions
    so that the motion spans at least ``motion_samples`` samples, at most ``max_rate``.

    The finger-tracking paper gives no rate. A fixed 100 Hz would leave a 0.1 s grasp 10 samples
    (80 degrees per sample on the distal phalanx); the MPU-9250 samples its
    gyroscope at up to 8 kHz, its accelerometer at up to 4 kHz. The white noise
    scales with the rate (density times sqrt(rate)), as a sensor whose low-pass
    filter matches its output rate.
    """
    return min(max(rate, motion_samples / move_s), max_rate)


def flexion_angle(q_ws: Array) -> Array:
    """The flexion angle theta of a link from its orientation (the finger-tracking paper, sec. 2.1), heading-free.

    In the vertical flexion plane theta is fixed by the link's inclination:
    world up seen from the sensor, ``q* (0, 0, 1) q``, is ``(0, sin theta,
    cos theta)``, so ``theta = atan2(up_y, up_z)``, the same formula as
    :func:`gravity_angle` applied to the estimate. A heading error (a turn about
    world z, which the flat model of the paper cannot have and a filter without
    a heading reference accumulates) leaves it unchanged; an out-of-plane tilt
    enters only as the projection onto the flexion plane.
    """
    up = Q.rotate(Q.conjugate(q_ws), [0.0, 0.0, 1.0])
    return np.arctan2(up[..., 1], up[..., 2])


def gravity_angle(acc: Array) -> Array:
    """The slow-motion estimate, the finger-tracking paper, sec. 2.2.2, sample by sample: theta from gravity alone.

    The paper's ``atan2(f3, f2)`` in its axes; in ours the specific force at
    rest is ``(0, g sin theta, g cos theta)`` (module docstring), so
    ``theta = atan2(f_y, f_z)``. The metacarpus is still (a_0 = 0), so nothing
    is subtracted; the sensor's own acceleration mu is the error (eq. 7).
    """
    return np.arctan2(acc[..., 1], acc[..., 2])


def integrated_angle(gyr_x: Array, theta0: Array, rate: float) -> Array:
    """The fast-motion estimate, the finger-tracking paper, sec. 2.2.3: ``theta_t = int(theta_{t-1}, omega)``
    from the true initial angle (sec. 3: "the known accurate initial estimate").

    Flat model: theta turns about x, so only the gyroscope's x axis counts. The
    step is the trapezoid rule (the paper uses Runge-Kutta; with rates known only
    at the samples the trapezoid is its second-order form). ``gyr_x`` is (N, ...),
    ``theta0`` the angles at sample 0.
    """
    steps = 0.5 * (gyr_x[1:] + gyr_x[:-1]) / rate
    return theta0 + np.concatenate([np.zeros_like(gyr_x[:1]), np.cumsum(steps, axis=0)])


def _filter_params(name: str, sensor: sim.SensorSpec, chain: sim.Chain, rate: float) -> dict:
    """Settings of the finger-tracking paper's filters for one finger sensor, from the paper and the data sheet.

    Both are set for an MPU-9250 as its data sheet describes it, the same in
    every error series (the paper's filters do not know which series runs):
    the gyroscope error per axis is ``omega_err`` = the zero-rate offset bound
    plus the white noise's standard deviation at this rate.

    - switching (sec. 2.2.4-2.2.5): ``lever`` is the bound's ``(i_k + 1) l_max``
      (phalanx i_k counted from 0, so i_k + 1 is the sensor's link index in
      :func:`tracker.sim.finger_chain`); ``gyro_error`` = ``omega_err``, the
      AVS deviation ``|Delta omega|`` of eq. 8.
    - hinge (sec. 2.3): the flexion-plane normal is x in the sensor (the hinge
      axis, sec. 2.1) and x in the world (the metacarpus is still at identity);
      a static beta (sec. 3) by Madgwick's rule ``beta = sqrt(3/4) omega_err``
      (the filter gain for a gyroscope error of omega_err on each axis; [M10] in
      :mod:`tracker.fusion.madgwick`): a smaller one cannot keep up with the
      offsets, "the divergence of the estimate over time" (sec. 3).
    """
    omega_err = sim.GYR_OFFSET_MAX + sim.GYR_NOISE_DENSITY * math.sqrt(rate)
    if name == "switching":
        l_max = max(link.length_m for link in chain.links)
        return {"lever": sensor.link * l_max, "gyro_error": omega_err}
    return {"hinge_sensor": (1.0, 0.0, 0.0), "hinge_world": (1.0, 0.0, 0.0),
            "beta": math.sqrt(0.75) * omega_err}


def grasp_estimates(data: sim.SimData, chain: sim.Chain, rate: float) -> dict[str, Array]:
    """Each algorithm's flexion angles (N, sensors) for one simulated grasp (the finger-tracking paper, sec. 3).

    The two filters run through the common interface (``make(name).run``) from
    their own start: levelled by the first accelerometer sample, during the
    paper's still interval t_d.
    """
    theta0 = flexion_angle(data.truth.q_sensors[0])
    estimates = {"gravity": gravity_angle(data.acc),
                 "integration": integrated_angle(data.gyr[..., 0], theta0, rate)}
    for name in ("switching", "hinge"):
        estimates[name] = np.stack(
            [flexion_angle(make(name, **_filter_params(name, s, chain, rate))
                           .run(data.gyr[:, k], data.acc[:, k], None, rate))
             for k, s in enumerate(chain.sensors)], axis=1)
    return estimates


def rms_error_deg(estimate: Array, truth: Array) -> float:
    """RMS over all samples and sensors of the flexion-angle error, wrapped to (-180, 180] degrees.

    The finger-tracking paper, Figure 10: "the RMS of the algorithms' estimation error over the
    course of the whole movement". The integration estimate is continuous, so
    wrapping changes it only where its error passes half a turn.
    """
    error = np.angle(np.exp(1j * (estimate - truth)))
    return math.degrees(math.sqrt(float(np.mean(error**2))))


def grasp_errors(move_s: float, rate: float, errors: sim.SensorErrors, seed: int) -> dict[str, float]:
    """One test of the finger-tracking paper, sec. 3: simulate the grasp, run every algorithm, their RMS errors."""
    chain = sim.finger_chain()
    data = sim.Simulator(chain, sim.grasp(move_s, GRASP_DELAY_S), errors, seed=seed
                         ).simulate(GRASP_DELAY_S + move_s, rate)
    truth = flexion_angle(data.truth.q_sensors)
    return {name: rms_error_deg(est, truth)
            for name, est in grasp_estimates(data, chain, rate).items()}


def finger_grasp(durations: Sequence[float] = tuple(np.logspace(-1, 3, 32)), rate: float = 100.0,
                 max_rate: float = 1000.0, motion_samples: int = 100, seed: int = 0,
                 progress: Progress = None) -> dict:
    """The finger-tracking paper, sec. 3 and Figure 10: RMS flexion-angle error against grasp duration.

    For each error series (white noise; zero offset; both: MPU-9250 figures,
    :func:`paper_errors`) and each motion duration t_m: the grasp
    (:func:`tracker.sim.grasp`, still for t_d = 0.2 s first) on the finger
    (:func:`tracker.sim.finger_chain`, sensors on phalanges 1 and 2), sampled
    at :func:`grasp_rate`, estimated by gravity alone, by integration alone, by
    the switching filter and by the hinge (modified Madgwick) filter. The
    error quantity is the flexion angle of the sensed links (the paper's flat
    model estimates exactly that), pooled over both sensors and the whole run.
    The same seed gives every run the same sensor offsets.

    Two features of the curves that are ours, not the paper's: the integration
    error is wrapped (an orientation error), so it levels off near 104 deg (the
    RMS of an error spread evenly over a turn) beyond about 100 s with offsets;
    and the switching filter treats a gyroscope reading at the MPU-9250's full
    scale (2000 deg/s) as saturated and takes gravity instead
    (:mod:`tracker.fusion.switching`), which grasps shorter than about 0.4 s
    exceed on the distal sensor, hence its bump there.

    Runtime: at the default 100 Hz (raised to at most 1 kHz for motions under
    1 s) the default grid is about 0.4 million samples per sensor and series,
    about a minute on one core (the filters' per-sample Python loop dominates).
    Progress: one message per motion.
    """
    durations = [float(d) for d in durations]
    rates = [grasp_rate(d, rate, max_rate, motion_samples) for d in durations]
    series = {}
    for name, (noise, offset) in SERIES.items():
        errors = paper_errors(noise, offset)
        rms: dict[str, list[float]] = {a: [] for a in ALGORITHMS}
        for i, (move_s, r) in enumerate(zip(durations, rates)):
            for algorithm, value in grasp_errors(move_s, r, errors, seed).items():
                rms[algorithm].append(value)
            _report(progress, f"finger grasp, {name}: {i + 1}/{len(durations)} "
                              f"(t_m {move_s:.3g} s at {r:.0f} Hz)")
        series[name] = rms
    return {"durations_s": durations, "rates_hz": rates, "delay_s": GRASP_DELAY_S, "series": series}


# ------------------------------------------------------------ figures


def _figure(width_in: float, height_in: float):
    """A matplotlib Figure (no pyplot, no global state), or a clear error without matplotlib."""
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise RuntimeError("matplotlib is not installed: pip install '.[plot]'") from None
    return Figure(figsize=(width_in, height_in), layout="tight")


def _save_png(fig, path: str | os.PathLike) -> None:
    """Write the figure as PNG atomically (ARCHITECTURE.md: nothing saved is half-written)."""
    with AtomicFile(path, "wb") as f:
        fig.savefig(f.file, format="png", dpi=120)


def plot_static_drift(result: dict, path: str | os.PathLike) -> None:
    """The hand-tracking paper, Figs. 11-12 in one chart: each IMU's final error with correction off and on."""
    imus = result["imus"]
    fig = _figure(6, 4)
    ax = fig.subplots()
    x = np.arange(len(imus))
    ax.bar(x - 0.2, [m["error_deg_off"] for m in imus], 0.4, label="correction off")
    ax.bar(x + 0.2, [m["error_deg_on"] for m in imus], 0.4, label="correction on")
    ax.set_xticks(x, [f"{m['bias_dps']:g} deg/s" for m in imus])
    ax.set_xlabel("gyroscope bias (on each axis)")
    ax.set_ylabel(f"orientation error after {result['minutes']:g} min (deg)")
    ax.set_title("Static drift (the IMU and infrared hand-tracking paper, sec. 4.1)")
    ax.legend()
    _save_png(fig, path)


def plot_finger_grasp(result: dict, path: str | os.PathLike) -> None:
    """The finger-tracking paper, Figure 10: RMS error against motion duration, one panel per error series."""
    series = result["series"]
    fig = _figure(4.5 * len(series), 4)
    axes = np.atleast_1d(fig.subplots(1, len(series), sharey=True))
    for ax, (name, rms) in zip(axes, series.items()):
        for algorithm, values in rms.items():
            ax.loglog(result["durations_s"], values, marker=".", label=algorithm)
        ax.set_title(f"sensor errors: {name}")
        ax.set_xlabel("motion duration t_m (s)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("RMS flexion-angle error (deg)")
    axes[0].legend()
    fig.suptitle("Finger grasp (Inertial Sensor Based Solution for Finger Motion Tracking, Computers 9(2):40, 2020, "
                 "sec. 3, Figure 10)")
    _save_png(fig, path)
