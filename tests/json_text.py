"""Random JSON documents for property tests, including what ``json.dumps`` cannot write.

:class:`Raw` text goes into a document as it is (``NaN``, ``1e400``, a number of
70 digits), so the documents reach the readers' refusals as well as their values.
"""

from __future__ import annotations

import json

from hypothesis import strategies as st


class Raw(str):
    """Text put into a JSON document as it is (NaN, 1e400, 70 digits: what json.dumps cannot write)."""


def dumps(value: object) -> str:
    """``json.dumps`` of a value whose :class:`Raw` parts are written as they are."""
    if isinstance(value, Raw):
        return str(value)
    if isinstance(value, list):
        return "[" + ", ".join(map(dumps, value)) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)}: {dumps(v)}" for k, v in value.items()) + "}"
    return json.dumps(value)


LEAVES = (st.none() | st.booleans() | st.integers(-10**20, 10**20)
          | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=8))
RAW = st.sampled_from(["NaN", "Infinity", "-Infinity", "1e400", "9" * 70, "true", "null", '"1.0"']).map(Raw)
ANY = st.recursive(LEAVES | RAW, lambda inner: st.lists(inner, max_size=4)
                   | st.dictionaries(st.text(max_size=6), inner, max_size=4), max_leaves=12)
