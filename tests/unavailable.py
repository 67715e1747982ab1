"""Tests that need an optional tool or data set: skip where it is missing, fail under CI.

CI (``CI=true``, ``.ci/run``) installs everything the tests use, so there a
missing tool is a broken set-up, never a reason to skip.
"""

import os
from typing import NoReturn

import pytest


def unavailable(reason: str, ci_hint: str) -> NoReturn:
    """Skip with ``reason``; under ``CI=true`` fail instead, saying what CI must provide (``ci_hint``)."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason}; under CI {ci_hint}")
    pytest.skip(reason)
