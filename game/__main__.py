"""``energyball``: the game's command line (also ``python -m game``).

The game itself lands with the game issue; until then this says so and
points at what already works.
"""

from __future__ import annotations

import sys
from typing import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    print("EnergyBall: the game is not built yet. The tracker is: try\n"
          "  armtracker monitor --virtual     (a virtual board on a pty)\n"
          "  armtracker monitor               (your board, found by USB id)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
