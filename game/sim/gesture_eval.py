"""Measured gesture accuracy: simulated players through the real pipeline.

Each trial scripts a player (:mod:`game.sim.motion_model`: minimum-jerk reaches,
reaction times, tremor, idle fidgeting and walking), simulates the board's
sensors on them (:mod:`tracker.sim`, MPU-9250 errors, the flex circuit),
quantises and frames every sample as the firmware does, and decodes the
bytes. From there the game's own code runs: the ``default`` filter and flex
tracker (:mod:`game.body.tracking`) with the board's six-pose accelerometer
calibration (done once by its maker with the guided procedure, a simulated
maker following its prompts on the same board),
"hold still" and the two-pose wearing
calibration (:mod:`game.body.wearing`), the avatar and the gesture machine. The
launches it reports are matched to the ones the player made.

Matching: a reported launch belongs to a true one when it comes between the
start of the elbow's straightening (less 50 ms) and 400 ms after the elbow
crossed the launch threshold; each true launch takes at most one. Latency is
the time from that crossing to the report; aim error the angle between the
reported direction and where the arm truly pointed, split into a part across
(from the azimuth: what the heading gets wrong) and a part up (the elevation:
what the inclination gets wrong; :func:`aim_split_deg`), so a researcher sees
which part of the fusion a miss comes from. A report matching none is a false
launch; those inside idle stretches count toward the idle rate.
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from tracker import protocol as P
from tracker.calibration import LONGER_HOLD, LONGER_HOLD_S, BoardCalibration, StartupParams
from tracker.maker_sim import SimulatedMaker, calibrate
from tracker.sim_board import RATE_HZ, SimBoard

from ..body.avatar import Avatar, BodySettings
from ..body.gestures import GestureEvent, GestureMachine
from ..body.pose import ArmPose
from ..body.tracking import Tracking
from ..body.wearing import HOLD_S, POSE_WINDOW_S, arm_down_then_forward
from .motion_model import Interval, PlayerProfile, Session, TrueLaunch, session
from .session_bootstrap import percentile_interval

MATCH_BEFORE_S = 0.05
MATCH_AFTER_S = 0.4
CHUNK = 64  # bytes per decoder feed, about what a serial read returns
LATE_FRACTION = 0.75  # launches after this share of a session count as "late" (drift shows there)


@dataclass
class TrialResult:
    """What one simulated session produced."""

    true_launches: int = 0
    matched: int = 0
    false_launches: int = 0
    idle_false_launches: int = 0
    idle_minutes: float = 0.0
    latencies_ms: list[float] = field(default_factory=list)
    aim_errors_deg: list[float] = field(default_factory=list)
    late_aim_errors_deg: list[float] = field(default_factory=list)  # launches in the session's last quarter
    aim_split_deg: list[tuple[float, float]] = field(default_factory=list)  # each aim error's signed parts
    # across (azimuth) and up (elevation), degrees (aim_split_deg)
    late_aim_split_deg: list[tuple[float, float]] = field(default_factory=list)  # ... of the late launches
    calibration: str = ""  # what the calibrations said, for the user
    calibration_ok: bool = False  # the maker's, the hold's and the wearing calibration's first attempts all worked


def board_stream(sim_session: Session, profile: PlayerProfile, seed: int) -> list[P.RawSample]:
    """The session as the host receives it: simulated, quantised, framed, sent, decoded."""
    sim = profile.simulator(sim_session.motion, seed)
    samples_due = round(sim_session.duration_s * RATE_HZ)
    wire = SimBoard(sim, rate_hz=RATE_HZ).run_until((samples_due - 1) / RATE_HZ)
    decoder = P.FrameDecoder()
    samples: list[P.RawSample] = []
    for i in range(0, len(wire), CHUNK):
        samples += decoder.feed(wire[i:i + CHUNK])  # type: ignore[arg-type]
    return samples


def maker_calibration(profile: PlayerProfile, seed: int) -> tuple[BoardCalibration, str | None]:
    """The calibrations a maker does once per board (README), simulated on the same board.

    Exactly what ``armtracker calibrate accel``, ``calibrate mag`` and ``calibrate
    thermal`` run: the six-pose procedure (:class:`tracker.accel_procedure.AccelProcedure`,
    with the gyroscope's sensitivities from its turns), the magnetometer procedure
    (:class:`tracker.mag_procedure.MagProcedure`) and the warm-up
    (:class:`tracker.thermal.ThermalProcedure`), fed the board's quantised samples
    while a simulated maker (:class:`tracker.maker_sim.SimulatedMaker`, the board's
    errors drawn from the same seed as the session's) follows their prompts: lays the
    board on each face in turn, tumbles it through every orientation, then leaves it
    still from a cold power-up of its own (:func:`tracker.maker_sim.warm_up`). No player
    wears the board: no tremor, sway or strap reaches it. Returns the
    calibration and None, or what it has and why a procedure failed (a
    reported figure, never an exception).
    """
    cal, problems = calibrate(SimulatedMaker(profile.sensor_errors(), seed))
    return cal, "; ".join(problems) or None


def azimuth_elevation_deg(direction: Sequence[float]) -> tuple[float, float]:
    """A unit direction (x right, y forward, z up) as its azimuth from forward, clockwise seen
    from above, and its elevation above the horizontal, in degrees."""
    x, y, z = direction
    return math.degrees(math.atan2(x, y)), math.degrees(math.asin(max(-1.0, min(1.0, z))))


def aim_split_deg(reported: Sequence[float], true: Sequence[float]) -> tuple[float, float]:
    """How far ``reported`` aims from ``true`` across and up, signed, degrees: the azimuth's
    difference (wrapped to +-180) times the cosine of the true elevation, as a turn about the
    vertical moves a direction that far along the sphere, and the elevation's difference. For
    small errors they are the sides of a right triangle whose hypotenuse is the aim error."""
    (az, el), (true_az, true_el) = azimuth_elevation_deg(reported), azimuth_elevation_deg(true)
    across = (az - true_az + 180.0) % 360.0 - 180.0
    return across * math.cos(math.radians(true_el)), el - true_el


def _within(t: float, interval: Interval, last_s: float | None = None) -> bool:
    t0, t1 = interval
    return (t1 - last_s if last_s else t0) <= t < t1


def _held(samples: Sequence[P.RawSample], down: Interval, last_s: float | None = None) -> list[P.RawSample]:
    """The samples of the arm-down hold (its last ``last_s`` seconds)."""
    return [s for s in samples if _within(s.t, down, last_s)]


def _calibration(script: Session) -> tuple[Interval, Interval]:
    """The session's (arm down, arm forward) intervals: every session played here is scripted with them."""
    if script.calibration is None:
        raise ValueError("a session played as a player's first evening begins with the wearing calibration")
    return script.calibration


def _played(profile: PlayerProfile, seed: int, gestures: int,
            board: BoardCalibration) -> tuple[Session, list[P.RawSample], StartupParams | None]:
    """The session, its samples and how its hold is judged: the game's "hold still" first, and
    if that asks for a longer hold (a slow tremor, :data:`tracker.calibration.LONGER_HOLD`),
    the same player holding on as the game asks (``HOLD_S["longer"]``), judged over the longer hold."""
    script = session(profile, seed, gestures=gestures)
    samples = board_stream(script, profile, seed)
    if not Tracking(board=board).hold_still(_held(samples, _calibration(script)[0]))[0].hold_longer:
        return script, samples, None
    script = session(profile, seed, gestures=gestures, hold_on_s=HOLD_S["longer"])
    return script, board_stream(script, profile, seed), LONGER_HOLD


def run_trial(profile: PlayerProfile, seed: int, gestures: int = 10, magnetometer: bool = True) -> TrialResult:
    """One scripted session through the whole pipeline (``magnetometer`` False: 6D fusion).

    The calibrations are tried once, as a player on the first evening does:
    a failure is recorded (``calibration_ok`` false, the reason in
    ``calibration``) and play goes on with what the pipeline has.
    """
    board, maker_problem = maker_calibration(profile, seed)
    script, samples, hold_params = _played(profile, seed, gestures, board)
    down, forward = _calibration(script)
    still = _held(samples, down, LONGER_HOLD_S if hold_params else None)  # the game judges the whole longer hold
    tracking = Tracking(use_magnetometer=magnetometer, board=board)
    avatar = Avatar(BodySettings(upper_arm_m=profile.upper_arm_m, forearm_m=profile.forearm_m))
    machine = GestureMachine()
    result = TrialResult(true_launches=len(script.launches))
    down_poses: list[ArmPose] = []
    forward_poses: list[ArmPose] = []
    launches = []
    calibrated = False
    for s in samples:
        if not calibrated and s.t >= down[1] and not down_poses:
            # "Hold still" ended: learn the bias, then redo the hold with it.
            bias, redone = tracking.hold_still(still, hold_params)
            down_poses = [p for p, x in zip(redone, still) if _within(x.t, down, POSE_WINDOW_S)]
        pose = tracking.feed(s)
        if not calibrated:
            if _within(s.t, forward, POSE_WINDOW_S):
                forward_poses.append(pose)
            if s.t >= forward[1]:
                outcome = arm_down_then_forward(avatar, down_poses, forward_poses)
                said = [maker_problem] if maker_problem else []
                result.calibration = "; ".join(said + [bias.message, outcome.message])
                result.calibration_ok = maker_problem is None and bias.ok and outcome.ok
                avatar.wearing = outcome.wearing
                tracking.anchor_heading()
                calibrated = True
            continue
        launches += [e for e in machine.update(avatar.update(pose)) if e.kind == "launch"]
    late_from = LATE_FRACTION * script.duration_s
    score_launches(script.launches, script.idle_intervals, launches, result, late_from)
    return result


def score_launches(truth: Sequence[TrueLaunch], idle_intervals: Sequence[Interval],
                   launches: Sequence[GestureEvent], result: TrialResult,
                   late_from: float = math.inf) -> list[TrueLaunch]:
    """Match reported launches to the true ones (module docstring) into ``result``; the unmatched true ones.

    The aim errors of launches made from ``late_from`` on also go to ``late_aim_errors_deg``
    (and their split to ``late_aim_split_deg``).
    """
    unmatched = list(truth)
    for event in launches:
        match = next((x for x in unmatched
                      if x.t_straight_start - MATCH_BEFORE_S <= event.t <= x.t_straight + MATCH_AFTER_S), None)
        if match is None:
            result.false_launches += 1
            result.idle_false_launches += any(_within(event.t, i) for i in idle_intervals)
            continue
        unmatched.remove(match)
        result.matched += 1
        result.latencies_ms.append(1000.0 * (event.t - match.t_straight))
        cos = float(np.clip(np.dot(event.direction, match.direction_body), -1.0, 1.0))
        result.aim_errors_deg.append(math.degrees(math.acos(cos)))
        result.aim_split_deg.append(aim_split_deg(event.direction, match.direction_body))
        if match.t_straight >= late_from:
            result.late_aim_errors_deg.append(result.aim_errors_deg[-1])
            result.late_aim_split_deg.append(result.aim_split_deg[-1])
    result.idle_minutes = sum(t1 - t0 for t0, t1 in idle_intervals) / 60.0
    return unmatched


def _run(args: tuple[PlayerProfile, int, int, bool]) -> TrialResult:
    return run_trial(*args)


def _trials(players: dict[str, PlayerProfile], trials: int, seed: int, gestures: int,
            progress: Callable[[str], None] | None, workers: int,
            magnetometer: bool) -> dict[str, list[TrialResult]]:
    """Every player's trials (seeds seed, seed + 1, ...), spread over ``workers`` processes."""
    jobs = [(name, (profile, seed + k, gestures, magnetometer))
            for name, profile in players.items() for k in range(trials)]
    results: dict[str, list[TrialResult]] = {name: [] for name in players}
    with ProcessPoolExecutor(max_workers=max(1, workers)) as pool:
        for (name, _), r in zip(jobs, pool.map(_run, [job for _, job in jobs])):
            results[name].append(r)
            if progress:
                who = f"{name}: " if len(players) > 1 else ""
                progress(f"{who}trial {len(results[name])}/{trials}: {r.matched}/{r.true_launches} launches, "
                         f"{r.false_launches} false" + ("" if r.calibration_ok else f"; {r.calibration}"))
    return results


def evaluate(profile: PlayerProfile, trials: int, seed: int, gestures: int = 10,
             progress: Callable[[str], None] | None = None, workers: int = 2,
             magnetometer: bool = True) -> dict:
    """Run one player's trials (in parallel) and report the figures the README quotes."""
    return summarise(_trials({"player": profile}, trials, seed, gestures, progress, workers,
                             magnetometer)["player"])


def evaluate_envelope(players: dict[str, PlayerProfile], trials: int, seed: int, gestures: int = 10,
                      progress: Callable[[str], None] | None = None, workers: int = 2,
                      magnetometer: bool = True) -> dict:
    """Every player's report (the same seeds for each), by name: the envelope of the catalogue."""
    results = _trials(players, trials, seed, gestures, progress, workers, magnetometer)
    return {"players": {name: summarise(rs) for name, rs in results.items()}}


def summarise(results: list[TrialResult]) -> dict:
    """The JSON report over all trials."""
    matched = sum(r.matched for r in results)
    reported = matched + sum(r.false_launches for r in results)
    true = sum(r.true_launches for r in results)
    idle_minutes = sum(r.idle_minutes for r in results)
    latency = [x for r in results for x in r.latencies_ms]
    aim_by_session = [r.aim_errors_deg for r in results]
    aim = [x for errors in aim_by_session for x in errors]
    late = [x for r in results for x in r.late_aim_errors_deg]
    split = [x for r in results for x in r.aim_split_deg]
    late_split = [x for r in results for x in r.late_aim_split_deg]

    def pct(values: list[float], q: float) -> float | None:
        return round(float(np.percentile(values, q)), 2) if values else None

    return {
        "launch_precision": round(matched / reported, 4) if reported else None,
        "launch_recall": round(matched / true, 4) if true else None,
        "false_launches_per_min": round(sum(r.idle_false_launches for r in results) / idle_minutes, 4)
        if idle_minutes else None,
        "latency_ms_median": pct(latency, 50), "latency_ms_p95": pct(latency, 95),
        "aim_error_deg_median": pct(aim, 50),
        "aim_error_deg_median_ci95": percentile_interval(aim_by_session, 50),  # over other sessions
        "aim_error_deg_p95": pct(aim, 95),
        "aim_error_deg_p95_ci95": percentile_interval(aim_by_session, 95),
        "aim_error_deg_median_late": pct(late, 50),
        "aim_error_deg_median_late_ci95": percentile_interval([r.late_aim_errors_deg for r in results], 50),
        "aim_azimuth_error_deg_median": pct([abs(az) for az, _ in split], 50),
        "aim_elevation_error_deg_median": pct([abs(el) for _, el in split], 50),
        "aim_azimuth_error_deg_median_late": pct([abs(az) for az, _ in late_split], 50),
        "aim_elevation_error_deg_median_late": pct([abs(el) for _, el in late_split], 50),
        "calibration_ok_rate": round(sum(r.calibration_ok for r in results) / len(results), 4)
        if results else None,
        "trials": len(results), "launches": true, "idle_minutes": round(idle_minutes, 2),
        "false_launches": reported - matched,
    }
