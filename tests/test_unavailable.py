"""A missing tool skips a test on a developer's machine and fails it under CI."""

import pytest

from .unavailable import unavailable


def test_a_missing_tool_skips_with_its_reason(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    with pytest.raises(pytest.skip.Exception, match="no avr-gcc"):
        unavailable("no avr-gcc", "it must be installed")


def test_under_ci_a_missing_tool_fails_saying_what_ci_lacks(monkeypatch):
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="no avr-gcc; under CI it must be installed"):
        unavailable("no avr-gcc", "it must be installed")
