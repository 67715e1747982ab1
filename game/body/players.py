"""Per-player profiles: arm side and lengths, how the board is worn, the flex calibration.

Sec. 6 of Zhu & Shi notes that every person's flex response and wearing differ;
a profile keeps them per player so a calibration is done once. Profiles are
JSON files named after the player, written atomically, in
``$XDG_CONFIG_HOME/energyball/players`` (``~/.config/energyball/players``).
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

from tracker.atomic import atomic_write
from tracker.flex import FlexCalibration, FlexCalibrationError
from tracker.userjson import JSONInputError, read_json

from .avatar import BodySettings, Wearing

FORMAT = "energyball-player"
VERSION = 1
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9 _.-]{0,39}$")


class ProfileError(Exception):
    """A profile that cannot be loaded or saved, worded for the user."""


@dataclass(frozen=True)
class Player:
    """One player's settings."""

    name: str
    body: BodySettings = field(default_factory=BodySettings)
    wearing: Wearing = field(default_factory=Wearing)
    flex: FlexCalibration | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ProfileError(f"a player name is 1-40 letters, digits, spaces, '.', '_' or '-', "
                               f"starting with a letter or digit: {self.name!r} is not")

    def to_json(self) -> dict:
        return {"format": FORMAT, "version": VERSION, "name": self.name, "body": asdict(self.body),
                "wearing": {"mount": list(self.wearing.mount), "init": list(self.wearing.init)},
                "flex": self.flex.to_json() if self.flex else None}

    @classmethod
    def from_json(cls, d: object) -> "Player":
        """Inverse of :meth:`to_json`; a ProfileError naming what is wrong otherwise."""
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise ProfileError("not an EnergyBall player profile")
        if d.get("version") != VERSION:
            raise ProfileError(f"profile version {d.get('version')!r} is not {VERSION}")
        missing = [k for k in ("name", "body", "wearing") if k not in d]
        if missing:
            raise ProfileError(f"it lacks {', '.join(missing)}")
        try:
            worn = _object(d["wearing"], "wearing")
            wearing = Wearing(_quat(worn.get("mount")), _quat(worn.get("init")))
            flex = FlexCalibration.from_json(d["flex"]) if d.get("flex") is not None else None
            return cls(d["name"], _body(d["body"]), wearing, flex)
        except (TypeError, ValueError) as e:  # FlexCalibrationError is a ValueError
            raise ProfileError(f"a field is wrong ({e})") from None


def _object(value: object, what: str) -> dict:
    if not isinstance(value, dict):
        raise ValueError(f"{what} must be an object")
    return value


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _body(value: object) -> BodySettings:
    """BodySettings from the profile's object: known keys only, lengths as numbers (not true/false)."""
    d = _object(value, "body")
    known = {f.name: f for f in fields(BodySettings)}
    unknown = [k for k in d if k not in known]
    if unknown:
        raise ValueError(f"body has an unknown key {unknown[0]!r}")
    lengths = [k for k, v in d.items() if known[k].type in ("float", float) and not _number(v)]
    if lengths:
        raise ValueError(f"body.{lengths[0]} must be a number, not {d[lengths[0]]!r}")
    return BodySettings(**d)


def _quat(values: object) -> tuple[float, float, float, float]:
    if not (isinstance(values, list) and len(values) == 4 and all(map(_number, values))):
        raise ValueError(f"{values!r} is not a unit quaternion (4 numbers)")
    q = (float(values[0]), float(values[1]), float(values[2]), float(values[3]))
    if not 0.99 < sum(c * c for c in q) < 1.01:
        raise ValueError(f"{values!r} is not a unit quaternion")
    return q


def players_dir() -> Path:
    """Where profiles live."""
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "energyball" / "players"


def _path(name: str, directory: Path | None) -> Path:
    if not isinstance(name, str) or not _NAME.match(name):  # never a path outside the folder
        raise ProfileError(f"{name!r} is not a player name (1-40 letters, digits, spaces, '.', '_' or '-')")
    return (directory or players_dir()) / f"{name}.json"


def save(player: Player, directory: Path | None = None) -> Path:
    """Write a profile atomically; returns its path."""
    path = _path(player.name, directory)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, json.dumps(player.to_json(), indent=1))
    except OSError as e:
        raise ProfileError(f"cannot save the profile to {path}: {e.strerror or e}") from None
    return path


def load(name: str, directory: Path | None = None) -> Player:
    """The named player's profile."""
    path = _path(name, directory)
    try:
        data = read_json(path)
    except FileNotFoundError:
        raise ProfileError(f"no profile named {name!r} (looked for {path})") from None
    except JSONInputError as e:
        raise ProfileError(f"{path} is damaged: {e.problem}") from None
    except OSError as e:
        raise ProfileError(f"{path} cannot be read: {e.strerror or e}") from None
    try:
        return Player.from_json(data)
    except ProfileError as e:
        raise ProfileError(f"{path}: {e}") from None


def load_or_new(name: str, directory: Path | None = None) -> tuple[Player, str]:
    """The named profile, or a new one with defaults and a notice saying why."""
    try:
        return load(name, directory), f"loaded player {name!r}"
    except ProfileError as e:
        return Player(name), f"{e}; starting with defaults"


def names(directory: Path | None = None) -> list[str]:
    """Every saved player's name."""
    folder = directory or players_dir()
    return sorted(p.stem for p in folder.glob("*.json")) if folder.is_dir() else []
