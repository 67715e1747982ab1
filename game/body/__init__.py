"""The player's body: arm pose, avatar, wearing calibration, tracking, gestures, controls (no pygame)."""
