"""EnergyBall arm tracker: serial link, wire protocol, fusion, calibration (no pygame here)."""
