"""tracker.userjson: JSON read with limits; Python's json module is the oracle for what is accepted."""

import json
import os
import pickle
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tracker.userjson import (MAX_BYTES, MAX_DEPTH, MAX_NUMBER_CHARS, BadNumber, JSONInputError, parse_json,
                              read_json)

LEAVES = (st.none() | st.booleans() | st.integers(-10**40, 10**40)
          | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=12))
JSON_VALUES = st.recursive(LEAVES, lambda inner: st.lists(inner, max_size=5)
                           | st.dictionaries(st.text(max_size=8), inner, max_size=5), max_leaves=24)
# Text made of JSON's own pieces, so random strings often get deep into the parser.
JSONISH = st.text(st.sampled_from(list('[]{}",:.-+eE0123456789 \\ntrufalsNIy\x00\ud800')), max_size=80)


@settings(derandomize=True, max_examples=400)
@given(JSON_VALUES)
def test_any_finite_json_value_reads_as_json_loads_reads_it(value):
    text = json.dumps(value)
    assert parse_json(text, "x.json") == json.loads(text)
    assert parse_json(text.encode(), "x.json") == json.loads(text)
    assert parse_json(text, "x.json", lenient_numbers=True) == json.loads(text)


@settings(derandomize=True, max_examples=400)
@given(st.one_of(JSONISH, st.text(max_size=60), st.binary(max_size=60)))
def test_random_text_is_read_as_json_reads_it_or_refused_with_one_line(text):
    try:
        value = parse_json(text, "some/file.json")
    except JSONInputError as e:
        assert str(e).startswith("some/file.json: ") and "\n" not in str(e)
        return
    # accepted: then the json module reads the same value (the oracle)
    assert value == json.loads(text)


def test_nesting_is_counted_by_hand():
    deepest = "[" * MAX_DEPTH + "]" * MAX_DEPTH
    assert parse_json(deepest, "f") == json.loads(deepest)
    with pytest.raises(JSONInputError, match=f"f: nested {MAX_DEPTH + 1} deep; at most {MAX_DEPTH}"):
        parse_json("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1), "f")
    with pytest.raises(JSONInputError, match="nested 100000 deep"):  # json itself: RecursionError
        parse_json('{"a":' * 100_000 + "1" + "}" * 100_000, "f")
    # brackets inside strings (also after an escaped quote) are text, not nesting
    inside = '["' + "[{" * 100 + '\\"' + "[" * 50 + '"]'
    assert parse_json(inside, "f") == json.loads(inside)


def test_numbers_are_bounded_by_hand():
    longest = "1" * MAX_NUMBER_CHARS
    assert parse_json(f"[{longest}]", "f") == [int(longest)]
    with pytest.raises(JSONInputError, match=f"a number of {MAX_NUMBER_CHARS + 1} characters"):
        parse_json("1" * (MAX_NUMBER_CHARS + 1), "f")
    with pytest.raises(JSONInputError, match="a number of 400 characters"):  # int(): fine; float(): overflow
        parse_json('{"speed": ' + "9" * 400 + "}", "f")
    with pytest.raises(JSONInputError, match="1e400 is too large"):
        parse_json("[1e400]", "f")
    for constant in ("NaN", "Infinity", "-Infinity"):
        with pytest.raises(JSONInputError, match=f"{constant} is not a JSON number"):
            parse_json(f'{{"a": {constant}}}', "f")
    assert parse_json("[-0.0, 1e-400, 1.7976931348623157e308]", "f") == [0.0, 0.0, 1.7976931348623157e308]


def test_lenient_numbers_spoil_only_their_own_value():
    value = parse_json('{"a": NaN, "b": 1e400, "c": ' + "7" * 70 + ', "d": 2}', "f", lenient_numbers=True)
    assert value["d"] == 2 and value["a"] == BadNumber("NaN") and value["b"] == BadNumber("1e400")
    assert repr(value["a"]) == "NaN" and repr(value["c"]) == "777777777777...(70 characters)"


def test_size_encoding_and_byte_order_mark():
    with pytest.raises(JSONInputError, match="larger than 4 MB"):
        parse_json(b" " * (MAX_BYTES + 1), "f")
    with pytest.raises(JSONInputError, match="f: not UTF-8 text"):
        parse_json(b'{"a": "\xff"}', "f")
    assert parse_json("\ufeff[1]".encode(), "f") == [1]  # RFC 8259 sec. 8.1 allows ignoring it
    with pytest.raises(JSONInputError, match=r"f: not valid JSON \(Expecting value at line 1, column 1\)"):
        parse_json("", "f")


def test_read_json_names_the_file_and_refuses_what_is_not_a_regular_file(tmp_path):
    path = tmp_path / "a.json"
    path.write_text('{"k": [1, 2.5, "x"]}')
    assert read_json(path) == {"k": [1, 2.5, "x"]}
    path.write_text('{"k": ')
    with pytest.raises(JSONInputError, match=f"^{path}: not valid JSON"):
        read_json(path)
    with pytest.raises(JSONInputError, match="^~/a.json: not valid JSON"):
        read_json(path, source="~/a.json")
    with pytest.raises(JSONInputError, match="not a regular file"):
        read_json(tmp_path)
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)  # no writer: a blocking open would hang here
    with pytest.raises(JSONInputError, match="fifo.json: not a regular file"):
        read_json(fifo)
    with pytest.raises(FileNotFoundError):
        read_json(tmp_path / "missing.json")


def test_the_error_survives_pickling_as_worker_processes_send_it():
    e = pickle.loads(pickle.dumps(JSONInputError("f.json", "nested 40 deep")))
    assert (str(e), e.source, e.problem) == ("f.json: nested 40 deep", "f.json", "nested 40 deep")
    assert isinstance(e, ValueError)


# ----------------------------------------------------------------- the tracker's loaders that use it

from tracker import calibration as C  # noqa: E402
from tracker.flex import FlexCalibration, FlexCalibrationError  # noqa: E402

from ..json_text import ANY, RAW, Raw, dumps  # noqa: E402




def edited(good: dict, keys: list[str]) -> st.SearchStrategy:
    """``good`` with up to three of ``keys`` given random values (a row of numbers, often)."""
    values = ANY | st.lists(st.floats(-1e3, 1e3) | RAW, min_size=2, max_size=4) | st.lists(
        st.lists(st.floats(-2, 2) | RAW, min_size=3, max_size=3), min_size=3, max_size=3)
    return st.dictionaries(st.sampled_from(keys), values, max_size=3).map(lambda ch: dumps({**good, **ch}))


RANDOM = st.one_of(ANY.map(dumps), st.binary(max_size=80), JSONISH)
BOARD = C.BoardCalibration("b1").to_json()
FLEX = FlexCalibration.paper().to_json()


def written(folder: Path, name: str, content) -> bytes:
    data = content if isinstance(content, bytes) else content.encode("utf-8", "surrogatepass")
    (folder / name).write_bytes(data)
    return data


@settings(derandomize=True, max_examples=300)
@given(st.one_of(edited(BOARD, list(BOARD)), RANDOM))
def test_any_board_calibration_file_loads_or_is_one_calibration_file_error(content):
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        data = written(folder, "b1.json", content)
        try:
            cal = C.load("b1", folder)
        except C.CalibrationFileError as e:
            assert str(e).startswith(f"board calibration {folder / 'b1.json'}: ") and "\n" not in str(e)
        else:  # what loaded is what a save would write again
            assert C.BoardCalibration.from_json(json.loads(json.dumps(cal.to_json()))).to_json() == cal.to_json()
        fallback, notice = C.load_or_default("b1", folder)  # never raises
        assert isinstance(fallback, C.BoardCalibration) and "\n" not in notice
        assert [p.name for p in folder.iterdir()] == ["b1.json"] and (folder / "b1.json").read_bytes() == data


@settings(derandomize=True, max_examples=300)
@given(st.one_of(edited(FLEX, list(FLEX)), RANDOM))
def test_any_flex_calibration_file_loads_or_is_one_flex_calibration_error(content):
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        data = written(folder, "f.json", content)
        try:
            cal = FlexCalibration.load(folder / "f.json")
        except FlexCalibrationError as e:
            assert str(e).startswith(f"{folder / 'f.json'}: ") and "\n" not in str(e)
        else:
            assert 0 <= min(cal.adc_straight, cal.adc_bent) and max(cal.adc_straight, cal.adc_bent) <= 1023
            assert 0 < cal.bent_deg <= 180 and abs(cal.curve) <= 1
            assert cal.degrees_one(500.0) == cal.degrees_one(500.0)  # a number, never NaN
        assert [p.name for p in folder.iterdir()] == ["f.json"] and (folder / "f.json").read_bytes() == data


@pytest.mark.parametrize("field, text, words", [
    ("gyro_bias", "[" + "9" * 400 + ", 0, 0]", "a number of 400 characters"),
    ("gyro_bias", "[1e400, 0, 0]", "1e400 is too large"),
    ("gyro_bias", "[NaN, 0, 0]", "NaN is not a JSON number"),
    ("gyro_bias", "[true, 0, 0]", "gyro_bias must be a list of numbers"),
    ("gyro_bias", '["1", 0, 0]', "gyro_bias must be a list of numbers"),
    ("acc_misalignment", "[[1, 0, 0], [0, 1, 0], [0, 0, [1]]]", "acc_misalignment must be a list of numbers"),
    ("mag_soft_iron", "[[1, 0, 0], [0, 1, 0]]", "mag_soft_iron must be 3 x 3 finite numbers"),
])
def test_a_board_calibration_value_is_refused_by_hand(tmp_path, field, text, words):
    good = json.dumps({**BOARD, field: "X"}).replace('"X"', text)
    (tmp_path / "b1.json").write_text(good)
    with pytest.raises(C.CalibrationFileError, match=words) as e:
        C.load("b1", tmp_path)
    assert "\n" not in str(e.value) and str(tmp_path / "b1.json") in str(e.value)


def test_a_board_calibration_nested_100000_deep_is_one_line(tmp_path):
    (tmp_path / "b1.json").write_text("[" * 100_000 + "]" * 100_000)
    cal, notice = C.load_or_default("b1", tmp_path)
    assert cal.to_json() == BOARD
    assert notice == (f"board calibration {tmp_path / 'b1.json'}: it is damaged (nested 100000 deep; at most "
                      f"32 is read); delete it or calibrate again; using the default calibration")


@pytest.mark.parametrize("changes, words", [
    ({"adc_straight": Raw("9" * 400)}, "bad JSON: a number of 400 characters"),
    ({"adc_straight": 2000}, "counts must lie within the ADC's 0-1023"),
    ({"adc_bent": -5}, "counts must lie within the ADC's 0-1023"),
    ({"bent_deg": 720}, "bent angle 720 must be at most 180"),
    ({"curve": Raw("Infinity")}, "bad JSON: Infinity is not a JSON number"),
])
def test_a_flex_calibration_value_is_refused_by_hand(tmp_path, changes, words):
    path = tmp_path / "f.json"
    path.write_text(dumps({**FLEX, **changes}))
    with pytest.raises(FlexCalibrationError, match=words) as e:
        FlexCalibration.load(path)
    assert str(e.value).startswith(f"{path}: ") and "\n" not in str(e.value)
