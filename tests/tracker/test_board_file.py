"""The per-board calibration file: the board's id from its HELLO, a record of when each procedure was done,
each procedure keeping the other's fields, a damaged file kept aside before it is replaced; and how the
calibrate command notices a pulled cable."""

from __future__ import annotations

import json
import tempfile
from dataclasses import replace
from datetime import datetime

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tracker import calibration as C
from tracker.board import hello as board_hello
from tracker.calibrate_cli import LinkWatch
from tracker.protocol import BoardError, Mode

HELLO = board_hello(200, Mode.RAW, True, 16, 2000, BoardError.NONE, has_mag=True)


def fitted(procedure: str, k: float) -> C.BoardCalibration:
    """A calibration whose ``procedure`` fields are all set from ``k`` (the others at their defaults)."""
    if procedure == "accel":
        return C.BoardCalibration("b1", acc_offset=[k, -k, 2 * k], acc_scale=[1 + k / 100, 1, 1 - k / 100],
                                  acc_misalignment=np.eye(3) + np.triu(np.full((3, 3), k / 1000), 1))
    return C.BoardCalibration("b1", mag_hard_iron=[k, 2 * k, -k], mag_soft_iron=np.eye(3) * (1 + k / 100))


def record(procedure: str, k: float) -> C.ProcedureRecord:
    figures = {"residual_m_s2": k} if procedure == "accel" else {"residual_ut": k, "strength_ut": 45.0, "dip_deg": 60.0}
    return C.ProcedureRecord.now(procedure, figures)


def fields_of(cal: C.BoardCalibration, procedure: str) -> list:
    return [getattr(cal, f).tolist() for f in C.PROCEDURES[procedure]]


def test_the_board_id_is_the_imu_of_the_hello_and_the_virtual_board_has_its_own():
    assert C.board_id_of(HELLO) == "imu-71"  # PROTOCOL.md 5.1: WHO_AM_I 0x71 for the MPU-9250
    no_mag = replace(HELLO, mag_whoami=0, errors=BoardError.MAG_MISSING, firmware="2.3.0", rate_hz=100)
    assert C.board_id_of(no_mag) == "imu-71"  # a new firmware or a silent AK8963 keep the calibration
    assert C.board_id_of(replace(HELLO, imu_whoami=0x73)) == "imu-73"
    assert C.board_id_of(HELLO, virtual=True) == "virtual-imu-71"
    assert C.calibration_path(C.board_id_of(HELLO), "/x").name == "imu-71.json"


def test_each_procedure_keeps_the_others_fields_record_and_the_gyro_bias(tmp_path):
    C.save(C.BoardCalibration("b1", gyro_bias=[0.01, 0.02, 0.03]), tmp_path)
    accel, mag = record("accel", 0.004), record("mag", 0.3)
    path, copied = C.save_procedure("b1", fitted("accel", 0.5), accel, tmp_path)
    assert path == tmp_path / "b1.json" and copied is None
    C.save_procedure("b1", fitted("mag", 30.0), mag, tmp_path)
    cal = C.load("b1", tmp_path)
    assert fields_of(cal, "accel") == fields_of(fitted("accel", 0.5), "accel")
    assert fields_of(cal, "mag") == fields_of(fitted("mag", 30.0), "mag")
    assert cal.gyro_bias.tolist() == [0.01, 0.02, 0.03]
    assert cal.procedures == (accel, mag)
    again = record("accel", 0.002)
    C.save_procedure("b1", fitted("accel", 0.1), again, tmp_path)  # accel again: mag untouched
    cal = C.load("b1", tmp_path)
    assert cal.record("accel") == again and cal.record("mag") == mag
    assert fields_of(cal, "mag") == fields_of(fitted("mag", 30.0), "mag")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b1.json"]


@settings(derandomize=True, max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(list(C.PROCEDURES)), st.floats(-50, 50)), min_size=1, max_size=6))
def test_the_file_holds_the_last_save_of_each_procedure(saves):
    with tempfile.TemporaryDirectory() as d:
        last: dict[str, tuple[C.BoardCalibration, C.ProcedureRecord]] = {}
        for procedure, k in saves:
            rec = record(procedure, abs(k))
            C.save_procedure("b1", fitted(procedure, k), rec, d)
            last[procedure] = (fitted(procedure, k), rec)
        cal = C.load("b1", d)
        default = C.BoardCalibration("b1")
        for procedure in C.PROCEDURES:
            want, rec = last.get(procedure, (default, None))
            assert fields_of(cal, procedure) == fields_of(want, procedure)
            assert cal.record(procedure) == rec


def test_records_say_when_in_local_time_and_old_files_without_them_still_load(tmp_path):
    rec = C.ProcedureRecord.now("mag", {"residual_ut": 0.4, "strength_ut": 47.0, "dip_deg": 63.0})
    at = datetime.fromisoformat(rec.done_at)
    assert at.tzinfo is not None and abs((datetime.now().astimezone() - at).total_seconds()) < 5
    assert rec.when == at.strftime("%Y-%m-%d %H:%M")
    old = {k: v for k, v in C.BoardCalibration("b1", acc_offset=[0.1, 0, 0]).to_json().items() if k != "procedures"}
    (tmp_path / "b1.json").write_text(json.dumps(old))
    cal = C.load("b1", tmp_path)
    assert cal.procedures == () and cal.acc_offset.tolist() == [0.1, 0, 0]
    assert C.done_text(cal) == ("accelerometer not calibrated, magnetometer not calibrated, "
                                "warm-up drift not calibrated")


@pytest.mark.parametrize("procedures, words", [
    ({"gyro": {"done_at": "2025-01-01T10:00:00+01:00"}}, "unknown procedure 'gyro' (known: accel, mag, thermal)"),
    ({"accel": {"done_at": "yesterday"}}, "accel: done_at must be a date and time"),
    ({"accel": {"residual_m_s2": 0.1}}, "procedures: accel must be an object with done_at"),
    ({"mag": {"done_at": "2025-01-01T10:00:00", "residual_ut": True}}, "procedures: mag: residual_ut must be a number"),
    ({"mag": {"done_at": "2025-01-01T10:00:00", "Bad Name": 1}}, "mag: 'Bad Name' is not a figure's name"),
    ([1], "procedures must be an object of accel and mag"),
])
def test_a_bad_record_is_one_clear_line(tmp_path, procedures, words):
    (tmp_path / "b1.json").write_text(json.dumps({**C.BoardCalibration("b1").to_json(), "procedures": procedures}))
    with pytest.raises(C.CalibrationFileError) as e:
        C.load("b1", tmp_path)
    assert words in str(e.value) and "\n" not in str(e.value) and str(tmp_path / "b1.json") in str(e.value)


def test_a_damaged_file_is_copied_aside_before_it_is_replaced(tmp_path):
    path = tmp_path / "b1.json"
    path.write_bytes(b"{broken")
    assert C.damage("b1", tmp_path).startswith(f"board calibration {path}: it is damaged")
    _, copied = C.save_procedure("b1", fitted("accel", 1.0), record("accel", 0.0), tmp_path)
    assert copied == tmp_path / "b1.json.damaged" and copied.read_bytes() == b"{broken"
    assert C.damage("b1", tmp_path) == "" and C.load("b1", tmp_path).record("accel") is not None
    path.write_bytes(b"[1]")  # damaged again, differently: a second copy
    _, copied = C.save_procedure("b1", fitted("mag", 1.0), record("mag", 0.0), tmp_path)
    assert copied == tmp_path / "b1.json.damaged.2" and copied.read_bytes() == b"[1]"
    path.write_bytes(b"{broken")  # the first damage again: its copy is there already
    _, copied = C.save_procedure("b1", fitted("mag", 1.0), record("mag", 0.0), tmp_path)
    assert copied == tmp_path / "b1.json.damaged"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b1.json", "b1.json.damaged", "b1.json.damaged.2"]
    cal = C.load("b1", tmp_path)  # what the damaged file held is gone from the new one: the defaults and mag
    assert fields_of(cal, "accel") == fields_of(C.BoardCalibration("b1"), "accel") and cal.record("accel") is None


def test_a_file_that_is_no_file_is_never_replaced(tmp_path):
    (tmp_path / "b1.json").mkdir()
    with pytest.raises(C.CalibrationFileError, match="it is not a regular file; it is left as it is"):
        C.save_procedure("b1", fitted("accel", 1.0), record("accel", 0.0), tmp_path)
    assert (tmp_path / "b1.json").is_dir() and sorted(p.name for p in tmp_path.iterdir()) == ["b1.json"]


def test_load_for_hello_says_what_it_loaded_or_why_not(tmp_path):
    cal, notice = C.load_for_hello(None, tmp_path)
    assert cal.to_json() == C.BoardCalibration().to_json() and "did not identify itself" in notice
    cal, notice = C.load_for_hello(HELLO, tmp_path)
    assert cal.board_id == "imu-71" and cal.procedures == ()
    assert notice == (f"board calibration {tmp_path / 'imu-71.json'}: no calibration saved for this board yet "
                      "(armtracker calibrate accel, then calibrate mag); using the default calibration")
    rec = record("accel", 0.01)
    C.save_procedure("imu-71", fitted("accel", 0.2), rec, tmp_path)
    cal, notice = C.load_for_hello(HELLO, tmp_path)
    assert fields_of(cal, "accel") == fields_of(fitted("accel", 0.2), "accel")
    assert notice == (f"board calibration loaded from {tmp_path / 'imu-71.json'} "
                      f"(accelerometer {rec.when}, magnetometer not calibrated, warm-up drift not calibrated)")
    cal, notice = C.load_for_hello(HELLO, tmp_path, virtual=True)  # the real board's file is not the virtual's
    assert cal.procedures == () and "virtual-imu-71.json: no calibration saved" in notice


@pytest.mark.parametrize("polls, events", [
    # (connected, reconnects) at each poll -> (went away, came back) said at each
    ([(True, 0), (True, 0)], [(False, False), (False, False)]),
    ([(True, 0), (False, 0), (False, 0), (True, 1), (True, 1)],
     [(False, False), (True, False), (False, False), (False, True), (False, False)]),
    # a reconnection between two polls, never seen disconnected: away and back at once
    ([(True, 0), (True, 1), (True, 1)], [(False, False), (True, True), (False, False)]),
    # two outages
    ([(False, 0), (True, 1), (False, 1), (True, 2)], [(True, False), (False, True), (True, False), (False, True)]),
])
def test_link_watch_notices_each_outage_once(polls, events):
    watch = LinkWatch(0)
    assert [watch.update(c, r) for c, r in polls] == events
    assert watch.interruptions == sum(lost for lost, _ in events)
