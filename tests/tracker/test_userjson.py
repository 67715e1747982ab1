"""tracker.userjson: JSON read with limits; Python's json module is the oracle for what is accepted."""

import json
import os
import pickle

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
