"""Orientation filters, one module each behind one interface (:mod:`.base`).

``make(name)`` builds a filter by name; ``FILTERS`` lists them.
"""

from __future__ import annotations

from importlib import import_module

from .base import Filter, Flags

# Each name is a module of this package that defines its filter class as FILTER_CLASS.
FILTERS = ("complementary", "gravmag", "madgwick", "switching", "hinge", "default")


def make(name: str, **params: object) -> Filter:
    """A new filter by name, with optional parameter overrides."""
    if name not in FILTERS:
        raise ValueError(f"unknown filter {name!r}; choose from {', '.join(FILTERS)}")
    module = import_module(f".{name}", __name__)
    return module.FILTER_CLASS(**params)


__all__ = ["FILTERS", "Filter", "Flags", "make"]
