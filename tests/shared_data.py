"""Where the tests find ``../shared/data`` (beside the checkout; environment variables override).

Paths are taken from the tests' own checkout, never from the package under test, so they
hold when that package is the compiled build's installed copy.
"""

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = ROOT.parent / "shared" / "data"
BROAD = Path(os.environ.get("ENERGYBALL_BROAD", SHARED_DATA / "broad"))
REAL_ARM = Path(os.environ.get("ENERGYBALL_REAL_ARM", SHARED_DATA / "real-arm" / "qmt_full_body_arms.npz"))
