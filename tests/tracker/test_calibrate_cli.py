"""`armtracker calibrate accel|mag|thermal|show` and `monitor`'s use of the board file, run as a maker runs them.

Each procedure runs through the real command in its own process, on a virtual
board served on a real pty and read through tracker.link, with the simulated
maker following the prompts in real time. The long runs start together in one
module fixture (each is mostly waiting for the board's samples) and every test
then reads what they did; the issue's bounds are the truth the recovered errors
are held to (offset <= 5 mg, scale <= 0.3 %, hard iron <= 2 uT, soft iron <= 2 %).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from tracker import calibration as C

from ..commands import ROOT, terminal_dispositions

BOARD = "virtual-imu-71"  # the virtual board's file: the real firmware's HELLO, marked virtual
DAMAGED = b'{"format": "energyball board calibration", "vers'
OFFSET_MG, SCALE_PCT, HARD_IRON_UT, SOFT_IRON_PCT = 5.0, 0.3, 2.0, 2.0  # the bounds
EXTREMES = ("--hard-iron", "200", "--soft-iron", "20", "--room", "40", "--noise-scale", "2")  # worst_plausible


def env(home: Path) -> dict[str, str]:
    return {**os.environ, "HOME": str(home), "XDG_CONFIG_HOME": str(home / "config")}


def boards(home: Path) -> Path:
    return home / "config" / "energyball" / "boards"


def start(home: Path, *args: str) -> subprocess.Popen:
    home.mkdir(parents=True, exist_ok=True)
    return subprocess.Popen([sys.executable, "-m", "tracker", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, env=env(home),
                            stdin=subprocess.DEVNULL, preexec_fn=terminal_dispositions)


def run(home: Path, *args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    proc = start(home, *args)
    out, err = proc.communicate(timeout=timeout)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def refusal(r: subprocess.CompletedProcess, *words: str) -> str:
    """A refused procedure: exit 1, no traceback, and one line of its own (``armtracker: ...``) as the
    last of its progress lines, holding ``words``."""
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    mine = [line for line in r.stderr.splitlines() if line.startswith("armtracker:")]
    assert len(mine) == 1 and r.stderr.strip().splitlines()[-1] == mine[0], r.stderr
    for w in words:
        assert w in mine[0], (w, mine[0])
    return mine[0]


@dataclass
class Runs:
    """The finished runs of the module fixture, by name, and the homes they ran in."""

    results: dict[str, subprocess.CompletedProcess]
    homes: dict[str, Path]
    before: dict[str, bytes]  # the board files as they were before the runs

    def report(self, name: str) -> dict:
        r = self.results[name]
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout)


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> Runs:
    base = tmp_path_factory.mktemp("calibrate")
    homes = {name: base / name for name in ("both", "noisy", "magnet", "short", "faces", "warming", "warm")}
    folder = boards(homes["both"])
    folder.mkdir(parents=True)
    (folder / f"{BOARD}.json").write_bytes(DAMAGED)  # damaged before both procedures start
    good = C.BoardCalibration(BOARD, acc_offset=[0.1, 0.2, 0.3])
    C.save(good, boards(homes["magnet"]))
    before = {"magnet": (boards(homes["magnet"]) / f"{BOARD}.json").read_bytes()}
    specs = {
        # the accelerometer with every slip a maker makes (on a board on for ten minutes: 10 s measuring its
        # warming, then the poses): bumped mid-pose, a face laid down twice, the cable pulled for 1.5 s; and
        # the magnetometer at the catalogue's extremes, in the same home
        "accel": ("both", "calibrate", "accel", "--virtual", "--json", "--nudge", "11.5", "--repeat-face",
                  "--unplug", "1.5@24", "--seed", "1", "--powered-for", "600"),
        "mag": ("both", "calibrate", "mag", "--virtual", "--json", "--seed", "2", *EXTREMES),
        # the accelerometer at twice the data sheet's noise (worst_plausible's noise_scale) on a board just
        # plugged in (its poses wait some 80 s for the die to settle), and the magnetometer of a typical board
        "accel_noisy": ("noisy", "calibrate", "accel", "--virtual", "--json", "--noise-scale", "2", "--seed", "3"),
        "mag_typical": ("noisy", "calibrate", "mag", "--virtual", "--json", "--seed", "4"),
        # refusals: a magnet brought near, too little turning in the time given, too few faces
        "magnet": ("magnet", "calibrate", "mag", "--virtual", "--magnet", "3"),
        "short": ("short", "calibrate", "mag", "--virtual", "--seconds", "4"),
        "faces": ("faces", "calibrate", "accel", "--virtual", "--seconds", "3"),
        "warming": ("warming", "calibrate", "accel", "--virtual", "--seconds", "30"),
        "warm": ("warm", "calibrate", "thermal", "--virtual", "--seconds", "3"),
    }
    procs = {name: start(homes[spec[0]], *spec[1:]) for name, spec in specs.items()}
    results = {}
    for name, proc in procs.items():
        out, err = proc.communicate(timeout=240)
        results[name] = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
    return Runs(results, homes, before)


def saved(home: Path) -> dict:
    return json.loads((boards(home) / f"{BOARD}.json").read_text())


# ----------------------------------------------------------------- the procedures


def test_accel_recovers_the_boards_errors_and_saves_them(runs):
    for name in ("accel", "accel_noisy"):
        report = runs.report(name)
        assert report["procedure"] == "accel" and report["board_id"] == BOARD
        assert report["faces"][:6] == ["+z", "-z", "+x", "-x", "+y", "-y"]
        assert report["faces"][6:] == ["tilted 1", "tilted 2", "tilted 3", "tilted 4"]  # the leaning poses
        assert report["acc_offset_error_mg"] <= OFFSET_MG and report["acc_scale_error_pct"] <= SCALE_PCT, report
        # the gyroscope's sensitivities (of up to 3 % off) and cross-axis terms (2 %) from the turns; the cable
        # pulled mid-procedure breaks the chain of one of them; the accelerometer's skew from the leaning poses
        assert report["gyro_scale_error_pct"] < 0.2 and report["gyro_turns"] == (8 if name == "accel" else 9), report
        assert report["gyro_matrix_error_pct"] < 1.0 and report["acc_skew_error_pct"] < 0.5, report
        home = runs.homes["both" if name == "accel" else "noisy"]
        assert report["path"] == str(boards(home) / f"{BOARD}.json")
        file = saved(home)
        assert file["acc_offset"] == report["acc_offset"] and file["acc_scale"] == report["acc_scale"]
        assert file["procedures"]["accel"] == {"done_at": report["done_at"], "residual_m_s2": report["residual_m_s2"]}
        stdout = runs.results[name].stdout
        assert stdout.strip().startswith("{")  # JSON only on stdout


def test_a_board_just_plugged_in_holds_no_pose_until_its_die_settles(runs):
    said = runs.results["accel_noisy"].stderr.splitlines()
    warming = next(i for i, line in enumerate(said) if line.startswith("the board is warming"))
    assert "degC a minute: the poses wait until that is under 1" in said[warming]
    settled = next(i for i, line in enumerate(said) if line.startswith("the board's temperature has settled"))
    assert warming < settled < next(i for i, line in enumerate(said) if line.startswith("captured +z"))
    assert not any(line.startswith("the board is warming") for line in runs.results["accel"].stderr.splitlines())


def test_mag_recovers_hard_and_soft_iron_at_the_extremes_and_typically(runs):
    for name in ("mag", "mag_typical"):
        report = runs.report(name)
        assert report["mag_hard_iron_error_ut"] <= HARD_IRON_UT, report
        assert report["mag_soft_iron_error_pct"] <= SOFT_IRON_PCT, report
        # The simulated earth's field: (0, 20, -40) uT in ENU (tracker.motion.EARTH_FIELD_UT): 44.7 uT, dip
        # atan(40 / 20) = 63.4 deg; the room's disturbance (up to 40 uT at the extremes) adds to it where
        # the board is turned.
        assert 22 <= report["strength_ut"] <= 67 and 0 < report["dip_deg"] < 90
        assert report["residual_ut"] < 0.05 * report["strength_ut"]
        # started beside the accelerometer's run, before it saved its poses: no turn onto its frame, and why
        assert report["alignment_deg"] == 0 and "run calibrate accel first" in report["alignment_problem"]
        home = runs.homes["both" if name == "mag" else "noisy"]
        file = saved(home)
        assert file["mag_hard_iron"] == report["mag_hard_iron"] and file["mag_soft_iron"] == report["mag_soft_iron"]
        assert file["procedures"]["mag"]["done_at"] == report["done_at"]


def test_the_two_procedures_keep_each_others_fields(runs):
    # They ran at the same time in one home: whichever saved last read the file again and kept the other's.
    for home, accel, mag in (("both", "accel", "mag"), ("noisy", "accel_noisy", "mag_typical")):
        file, a, m = saved(runs.homes[home]), runs.report(accel), runs.report(mag)
        assert (file["acc_offset"], file["acc_scale"]) == (a["acc_offset"], a["acc_scale"])
        assert (file["mag_hard_iron"], file["mag_soft_iron"]) == (m["mag_hard_iron"], m["mag_soft_iron"])
        assert set(file["procedures"]) == {"accel", "mag"}
        cal = C.load(BOARD, boards(runs.homes[home]))
        assert cal.record("accel").done_at == a["done_at"] and cal.record("mag").done_at == m["done_at"]


def test_a_damaged_file_is_said_before_and_kept_beside_the_new_one(runs):
    accel, mag = runs.report("accel"), runs.report("mag")
    folder = boards(runs.homes["both"])
    copies = [r["damaged_copy"] for r in (accel, mag) if r["damaged_copy"]]
    assert copies == [str(folder / f"{BOARD}.json.damaged")]  # the first to save kept it; the second found it good
    assert (folder / f"{BOARD}.json.damaged").read_bytes() == DAMAGED
    assert sorted(p.name for p in folder.iterdir()) == [f"{BOARD}.json", f"{BOARD}.json.damaged"]
    for name in ("accel", "mag"):
        said = runs.results[name].stderr.splitlines()
        warning = next(i for i, line in enumerate(said) if "damaged" in line)
        assert "keeping a copy as virtual-imu-71.json.damaged" in said[warning]
        first_prompt = ("lay the board flat", "turn the board")
        assert warning < next(i for i, line in enumerate(said) if line.startswith(first_prompt))


def test_the_maker_is_told_of_every_slip_and_the_procedure_resumes_after_a_pulled_cable(runs):
    report, said = runs.report("accel"), runs.results["accel"].stderr
    assert report["interruptions"] == 1
    lost = said.index("the board went away (cable pulled?)")
    back = said.index("the board is back: carrying on")
    assert lost < back < said.index("captured -y") and said.count("captured +z (1 of 10)") == 1
    assert "the board moved during the pose" in said  # the bump 1.5 s into the first hold, on +z
    assert "+z is already captured: put -z up" in said  # the face laid down again after its capture
    assert "Traceback" not in said


def test_refusals_are_one_clear_line_and_change_no_file(runs):
    line = refusal(runs.results["magnet"], "calibrate mag", "a magnet", "nothing was saved")
    assert "magnet" in line
    assert sorted(p.name for p in boards(runs.homes["magnet"]).iterdir()) == [f"{BOARD}.json"]
    assert (boards(runs.homes["magnet"]) / f"{BOARD}.json").read_bytes() == runs.before["magnet"]
    refusal(runs.results["short"], "calibrate mag: after 4 s, too little coverage", "nothing was saved")
    refusal(runs.results["faces"], "calibrate accel", "of 10 poses captured in 3 s", "still to do",
            "nothing was saved")
    line = refusal(runs.results["warming"], "calibrate accel", "0 of 10 poses captured in 30 s",
                   "the board was still warming (+", "degC a minute): leave it on a few minutes", "nothing was saved")
    # the typical board's die warms 1.7 degC a minute at power-on, with a time constant of 150 s
    # (tracker.sim.ErrorModel): the slope over the first 30 s is about 1.7 exp(-15 / 150) = 1.5
    assert 1.3 < float(line.split("warming (+")[1].split()[0]) < 1.7, line
    refusal(runs.results["warm"], "calibrate thermal: only 3 s of the board lying still (the fit needs 120)",
            "nothing was saved")
    assert "die 22.0" in runs.results["warm"].stderr  # the virtual board's TEMP frames: a cold die
    for name in ("short", "faces", "warming", "warm"):
        assert not boards(runs.homes[name]).exists()


# ----------------------------------------------------------------- show and monitor


def test_show_prints_what_is_saved_and_when(runs):
    home = runs.homes["both"]
    r = run(home, "calibrate", "show")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    cal = C.load(BOARD, boards(home))
    lines = r.stdout.splitlines()
    assert lines[0] == f"board {BOARD}: {boards(home) / (BOARD + '.json')}"
    accel, mag = cal.record("accel"), cal.record("mag")
    assert lines[1].split() == ["accelerometer", *accel.when.split(), "residual",
                                f"{dict(accel.figures)['residual_m_s2']:.4f}", "m/s^2"]
    assert f"offset ({' '.join(f'{x:+.4f}' for x in cal.acc_offset)}) m/s^2" in lines[2]
    cross = np.max(np.abs(cal.gyro_scale - np.diag(np.diag(cal.gyro_scale))))
    assert lines[2].endswith(f"gyroscope sensitivities ({' '.join(f'{x:.4f}' for x in np.diag(cal.gyro_scale))}), "
                             f"cross-axis up to {cross * 100:.2f} %")
    skew = np.max(np.abs(cal.acc_misalignment - np.eye(3)))
    assert f"misalignment up to {skew * 100:.2f} %" in lines[2] and 0.1 < skew * 100 < 4.0
    assert lines[3].split()[:3] == ["magnetometer", *mag.when.split()]
    assert f"hard iron ({' '.join(f'{x:+.2f}' for x in cal.mag_hard_iron)}) uT" in lines[4]
    shown = json.loads(run(home, "calibrate", "show", "--json").stdout)
    assert shown["boards"] == [{**cal.to_json(), "path": str(boards(home) / f"{BOARD}.json")}]
    assert shown["damaged"] == [] and shown["folder"] == str(boards(home))


def test_show_with_nothing_saved_or_a_damaged_file(tmp_path):
    r = run(tmp_path, "calibrate", "show")
    assert r.returncode == 0 and "no board calibration saved yet" in r.stdout
    boards(tmp_path).mkdir(parents=True)
    (boards(tmp_path) / "imu-71.json").write_bytes(DAMAGED)
    r = run(tmp_path, "calibrate", "show")
    assert r.returncode == 1 and "Traceback" not in r.stderr
    [line] = r.stderr.strip().splitlines()
    assert line.startswith(f"armtracker: board calibration {boards(tmp_path) / 'imu-71.json'}: it is damaged "
                           "(not valid JSON") and line.endswith("; delete it or calibrate again")
    assert (boards(tmp_path) / "imu-71.json").read_bytes() == DAMAGED


def test_monitor_applies_the_saved_calibration_and_says_so(runs):
    home = runs.homes["both"]
    r = run(home, "monitor", "--virtual", "--seconds", "1", "--json")
    assert r.returncode == 0, r.stderr
    path = boards(home) / f"{BOARD}.json"
    cal = C.load(BOARD, boards(home))
    assert r.stderr.splitlines()[0] == f"board calibration loaded from {path} ({C.done_text(cal)})"
    report = json.loads(r.stdout)
    assert report["calibration"]["board_id"] == BOARD
    assert report["calibration"]["procedures"] == saved(home)["procedures"]
    last, fixed = report["last"], report["last_calibrated"]
    # The board file's model, by hand: acc M ((a - offset) * scale), mag W (m - b).
    acc = cal.acc_misalignment @ ((np.array(last["acc"]) - cal.acc_offset) * cal.acc_scale)
    mag = cal.mag_soft_iron @ (np.array(last["mag"]) - cal.mag_hard_iron)
    assert fixed["acc"] == pytest.approx(acc, abs=1e-12) and fixed["mag"] == pytest.approx(mag, abs=1e-12)
    # the gyroscope: the six-pose procedure's sensitivities (no procedure sets its bias; no warm-up fit here)
    assert not np.array_equal(cal.gyro_scale, np.eye(3)) and not cal.gyro_thermal.any()
    assert fixed["gyr"] == pytest.approx(cal.gyro_scale @ np.array(last["gyr"]), abs=1e-12)


def test_monitor_with_a_damaged_file_uses_the_defaults_and_says_so(tmp_path):
    boards(tmp_path).mkdir(parents=True)
    path = boards(tmp_path) / f"{BOARD}.json"
    path.write_bytes(b"[1, 2]")
    r = run(tmp_path, "monitor", "--virtual", "--seconds", "0.5", "--json")
    assert r.returncode == 0, r.stderr
    notice = r.stderr.splitlines()[0]
    assert notice == (f"board calibration {path}: it is not an EnergyBall board calibration; delete it or "
                      "calibrate again; using the default calibration")
    report = json.loads(r.stdout)
    assert report["calibration"]["procedures"] == {} and report["last_calibrated"]["acc"] == report["last"]["acc"]
    assert path.read_bytes() == b"[1, 2]"


# ----------------------------------------------------------------- signals and options


@pytest.mark.parametrize("procedure, sig", [("accel", signal.SIGINT), ("mag", signal.SIGTERM)])
def test_a_signal_mid_procedure_saves_nothing(tmp_path, procedure, sig):
    proc = start(tmp_path, "calibrate", procedure, "--virtual")
    while "slowly" not in (line := proc.stderr.readline()) and "lay the board flat" not in line:
        assert line, "the command ended before its first prompt"
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 128 + sig and "Traceback" not in err, err
    assert err.strip().splitlines()[-1] == f"calibrate {procedure}: interrupted; nothing was saved"
    assert not boards(tmp_path).exists()


@pytest.mark.parametrize("args, code, words", [
    (("calibrate", "accel", "--port", "/dev/null", "--hard-iron", "10"), 1,
     "--hard-iron describes the simulated board and maker: it needs --virtual"),
    (("calibrate", "mag", "--virtual", "--unplug", "5"), 2, "--unplug: must be SECONDS@AT"),
    (("calibrate", "mag", "--virtual", "--soft-iron", "30"), 2, "--soft-iron: must be a number from 0 to 20"),
    (("calibrate", "accel", "--virtual", "--nudge", "1,x"), 2, "--nudge: must be seconds above 0"),
    (("calibrate", "accel", "--virtual", "--mode", "fused"), 2, "unrecognized arguments: --mode"),
])
def test_bad_options_are_one_clear_line(tmp_path, args, code, words):
    r = run(tmp_path, *args)
    assert r.returncode == code and "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], r.stderr
    assert not boards(tmp_path).exists()
