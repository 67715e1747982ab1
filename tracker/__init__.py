"""EnergyBall arm tracker: serial link, wire protocol, fusion, calibration (no pygame here)."""

from .compiled import warn_if_stale

warn_if_stale()
