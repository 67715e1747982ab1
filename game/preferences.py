"""Settings and high scores that persist between games.

Both are JSON files in ``$XDG_CONFIG_HOME/energyball`` (``~/.config/energyball``),
written atomically. A missing file means defaults; a damaged one means
defaults and a notice saying so (the damaged file is left for the user).
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

from tracker.atomic import atomic_write

MAX_SCORES = 10


def config_dir() -> Path:
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "energyball"


@dataclass(frozen=True)
class Preferences:
    """What the settings screen changes."""

    input: str = "auto"  # "auto" (a board if found, else keyboard), "keyboard", "virtual", or a port
    side: str = "right"
    volume: float = 0.8
    music_volume: float = 0.5
    fullscreen: bool = False
    raise_deg: float = 55.0  # gesture thresholds (game.gestures.GestureSettings)
    flex_on_deg: float = 55.0
    flex_off_deg: float = 25.0
    player: str = "Player"

    def __post_init__(self) -> None:
        if self.side not in ("right", "left"):
            raise ValueError(f"side must be right or left, not {self.side!r}")
        for name in ("volume", "music_volume"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be between 0 and 1")
        if not 0 < self.flex_off_deg < self.flex_on_deg < 180:
            raise ValueError("gesture thresholds must satisfy 0 < flex_off < flex_on < 180")


@dataclass(frozen=True)
class Score:
    name: str
    score: int
    wave: int
    date: str = field(default_factory=lambda: time.strftime("%Y-%m-%d"))


def _read(path: Path) -> tuple[object | None, str]:
    if not path.exists():
        return None, ""
    try:
        return json.loads(path.read_text()), ""
    except (OSError, ValueError) as e:
        return None, f"{path.name} is damaged ({e}); using defaults"


def load_preferences(directory: Path | None = None) -> tuple[Preferences, str]:
    """The saved preferences, or defaults and a notice."""
    path = (directory or config_dir()) / "settings.json"
    data, notice = _read(path)
    if not isinstance(data, dict):
        return Preferences(), notice or ("" if data is None else f"{path.name} is damaged; using defaults")
    known = {f.name for f in fields(Preferences)}
    try:
        return Preferences(**{k: v for k, v in data.items() if k in known}), ""
    except (TypeError, ValueError) as e:
        return Preferences(), f"{path.name} has a bad value ({e}); using defaults"


def save_preferences(prefs: Preferences, directory: Path | None = None) -> None:
    folder = directory or config_dir()
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write(folder / "settings.json", json.dumps(asdict(prefs), indent=1))


def load_scores(directory: Path | None = None) -> tuple[list[Score], str]:
    """The high-score table, best first, or an empty one and a notice."""
    path = (directory or config_dir()) / "scores.json"
    data, notice = _read(path)
    if data is None:
        return [], notice
    try:
        scores = [Score(str(d["name"]), int(d["score"]), int(d["wave"]), str(d["date"])) for d in data]
    except (TypeError, KeyError, ValueError) as e:
        return [], f"{path.name} is damaged ({e}); starting a new table"
    return sorted(scores, key=lambda s: -s.score)[:MAX_SCORES], ""


def add_score(scores: list[Score], score: Score, directory: Path | None = None) -> tuple[list[Score], int | None]:
    """The table with ``score`` in it (saved), and its rank (0 = best) or None if it did not make it."""
    table = sorted([*scores, score], key=lambda s: -s.score)[:MAX_SCORES]
    rank = next((i for i, s in enumerate(table) if s is score), None)
    folder = directory or config_dir()
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write(folder / "scores.json", json.dumps([asdict(s) for s in table], indent=1))
    return table, rank
