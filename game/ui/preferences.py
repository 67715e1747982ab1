"""Settings and high scores that persist between games.

Both are JSON files in ``$XDG_CONFIG_HOME/energyball`` (``~/.config/energyball``),
written atomically. What each value may hold is stated once, beside its field
(a :class:`Rule` in the field's metadata), and checked on construction and on
loading. Loading never fails and never writes:

- a missing file means defaults;
- a value that breaks its rule falls back to its default, the others are kept,
  and a notice names the file, the key and what was expected;
- damaged score entries are dropped, the good ones kept, with a notice;
- a file that cannot be read or parsed at all means defaults and a notice.

A file that did not load cleanly is never replaced silently: before the game
first saves over it, the damaged file is copied beside it as
``<name>.damaged`` (``<name>.damaged.2``, ... when that name holds another
copy), and when that copy cannot be made the save is refused (the caller says
so). What the user edited by hand is therefore never lost.
"""

from __future__ import annotations

import json
import os
import stat
import time
from dataclasses import Field, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any, Callable, Mapping

from tracker.atomic import atomic_write
from tracker.userjson import JSONInputError, read_json

MAX_SCORES = 10
MAX_DAMAGED_COPIES = 20  # settings.json.damaged, .damaged.2, ... (then saving is refused)


def config_dir() -> Path:
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "energyball"


def shown(path: Path) -> str:
    """``path`` as a notice shows it: under the home folder as ``~/...``."""
    try:
        return "~/" + path.relative_to(Path.home()).as_posix()
    except (ValueError, RuntimeError):  # not under home, or no home known
        return str(path)


# ----------------------------------------------------------------- rules


@dataclass(frozen=True)
class Rule:
    """What one value may hold: a type and a closed range, and what the value means.

    ``kind`` is ``bool``, ``int`` (a whole number, not a bool), ``float`` (any
    finite number, not a bool) or ``str``. For numbers ``low``-``high`` is
    the range; for text it is the length, and the text must be printable
    (no control characters, not only spaces), or one of ``choices``.
    """

    kind: type
    low: float = 0.0
    high: float = 0.0
    what: str = ""
    choices: tuple[str, ...] = ()

    def accepts(self, value: object) -> bool:
        if self.kind is bool:
            return isinstance(value, bool)
        if self.kind is str:
            if not isinstance(value, str):
                return False
            if self.choices:
                return value in self.choices
            return self.low <= len(value) <= self.high and value.isprintable() and not value.isspace()
        number = (int, float) if self.kind is float else (int,)
        return (isinstance(value, number) and not isinstance(value, bool)
                and self.low <= value <= self.high)  # NaN fails the comparison

    def expected(self) -> str:
        """What the rule wants, in words (for a notice)."""
        if self.kind is bool:
            return "true or false"
        if self.choices:
            return " or ".join(json.dumps(c) for c in self.choices)
        if self.kind is str:
            return f"text of {self.low:g} to {self.high:g} printable characters ({self.what})"
        if self.kind is int:
            return f"a whole number from {int(self.low)} to {int(self.high)} ({self.what})"
        return f"a number from {self.low:g} to {self.high:g} ({self.what})"


def _value(default: object, rule: Rule) -> Any:
    """A dataclass field whose metadata carries its rule."""
    return field(default=default, metadata={"rule": rule})


def rule_of(f: Field) -> Rule:
    return f.metadata["rule"]


def _problems(cls: type, values: Mapping[str, object]) -> dict[str, str]:
    """For each key of ``values`` naming a field of ``cls`` whose rule it breaks: what it must be."""
    return {f.name: f"{f.name} must be {rule_of(f).expected()}, not {_short(values[f.name])}"
            for f in fields(cls) if f.name in values and not rule_of(f).accepts(values[f.name])}


def _normalise(obj: object) -> None:
    """Check every field of a frozen dataclass ``obj`` against its rule (ValueError), numbers as floats."""
    values = {f.name: getattr(obj, f.name) for f in fields(obj)}  # type: ignore[arg-type]
    problems = _problems(type(obj), values)
    if problems:
        raise ValueError("; ".join(problems.values()))
    for f in fields(obj):  # type: ignore[arg-type]
        if rule_of(f).kind is float:
            object.__setattr__(obj, f.name, float(values[f.name]))


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:30] + f"...({len(text)} characters)"


NAME_RULE = Rule(str, 1, 40, "a player's name")

# ----------------------------------------------------------------- settings

FLEX_GAP_DEG = 10.0  # flex_off_deg lies at least this far below flex_on_deg (the hysteresis)
FLEX_STEP_DEG = 5.0  # what one left/right on "Launch flex" moves flex_on_deg


@dataclass(frozen=True)
class Preferences:
    """What the settings screen changes; each value's rule (type and range) is beside it.

    The angles are game.body.gestures.GestureSettings' thresholds. The arm's
    elevation is 0 hanging down and 90 level: raising is at 20 degrees or
    more, so the lowering threshold (10 below, at most 35) stays above a
    hanging arm, and at most 120, which every arm reaches. The elbow's flex
    is 0 straight: flex-off (straight again, the launch) at 5 degrees or more,
    above a straight arm's few degrees of sensor jitter, flex-on at most 120,
    short of a full bend (the flex sensor's scale ends at 127, tracker.flex),
    and flex-off at least :data:`FLEX_GAP_DEG` below flex-on.
    """

    input: str = _value("auto", Rule(str, 1, 200, "'auto', 'keyboard', 'virtual' or a serial port"))
    side: str = _value("right", Rule(str, choices=("right", "left")))
    volume: float = _value(0.8, Rule(float, 0.0, 1.0, "loudness"))
    music_volume: float = _value(0.5, Rule(float, 0.0, 1.0, "loudness"))
    fullscreen: bool = _value(False, Rule(bool))
    raise_deg: float = _value(55.0, Rule(float, 20.0, 120.0, "arm elevation in degrees"))
    flex_on_deg: float = _value(55.0, Rule(float, 15.0, 120.0, "elbow flex in degrees"))
    flex_off_deg: float = _value(25.0, Rule(float, 5.0, 110.0, "elbow flex in degrees"))
    player: str = _value("Player", NAME_RULE)
    keep_sessions: int = _value(10, Rule(int, 0, 1000, "the newest sessions kept as recordings; 0: none"))

    def __post_init__(self) -> None:
        _normalise(self)
        problem = flex_pair_problem(self.flex_on_deg, self.flex_off_deg)
        if problem:
            raise ValueError(problem)


def flex_pair_problem(on: float, off: float) -> str:
    """What is wrong with a flex-on/flex-off pair, or "" (see :class:`Preferences`)."""
    if off + FLEX_GAP_DEG <= on:
        return ""
    return f"flex_off_deg ({off:g}) must be at least {FLEX_GAP_DEG:g} below flex_on_deg ({on:g})"


def step_flex_on(prefs: Preferences, step: int) -> Preferences:
    """``prefs`` with flex-on moved ``step`` notches, kept within its range and above flex-off's gap."""
    rule = rule_of(next(f for f in fields(Preferences) if f.name == "flex_on_deg"))
    on = min(rule.high, max(prefs.flex_off_deg + FLEX_GAP_DEG, prefs.flex_on_deg + FLEX_STEP_DEG * step))
    return Preferences(**{**asdict(prefs), "flex_on_deg": on})


def load_preferences(directory: Path | None = None) -> tuple[Preferences, list[str]]:
    """The saved preferences, with each bad value at its default; notices saying what was wrong."""
    return _load_settings(_file(directory, "settings.json"))


def save_preferences(prefs: Preferences, directory: Path | None = None) -> None:
    """Write the settings atomically (a damaged file is kept first; OSError if it cannot be)."""
    _save(_file(directory, "settings.json"), asdict(prefs), lambda p: not _load_settings(p)[1])


def _load_settings(path: Path) -> tuple[Preferences, list[str]]:
    data, problem, kept = _read(path)
    if problem:
        return Preferences(), [f"{problem}; using the default settings{kept}"]
    if data is _NO_FILE:
        return Preferences(), []
    if not isinstance(data, dict):
        return Preferences(), [f"{shown(path)}: expected an object of settings, not {_kind(data)}; "
                               f"using the default settings{kept}"]
    defaults = Preferences()
    known = [f.name for f in fields(Preferences)]
    problems = _problems(Preferences, data)
    values = {k: v for k, v in data.items() if k in known and k not in problems}
    notices = [f"{shown(path)}: {text}; using {_short(getattr(defaults, k))}" for k, text in problems.items()]
    pair = flex_pair_problem(float(values.get("flex_on_deg", defaults.flex_on_deg)),
                             float(values.get("flex_off_deg", defaults.flex_off_deg)))
    if pair:
        values = {k: v for k, v in values.items() if k not in ("flex_on_deg", "flex_off_deg")}
        notices.append(f"{shown(path)}: {pair}; using {defaults.flex_on_deg:g} and {defaults.flex_off_deg:g}")
    unknown = [k for k in data if k not in known]
    if unknown:
        notices.append(f"{shown(path)}: unknown setting {_short(unknown[0])} ignored")
    if notices:
        notices[-1] += kept
    return Preferences(**values), notices


# ----------------------------------------------------------------- high scores


def _today() -> str:
    return time.strftime("%Y-%m-%d")


@dataclass(frozen=True)
class Score:
    """One row of the high-score table; each value's rule is beside it."""

    name: str = field(metadata={"rule": NAME_RULE})
    score: int = field(metadata={"rule": Rule(int, 0, 1e12, "points")})
    wave: int = field(metadata={"rule": Rule(int, 0, 1e6, "the wave reached")})
    date: str = field(default_factory=_today, metadata={"rule": Rule(str, 1, 32, "the day it was made")})

    def __post_init__(self) -> None:
        _normalise(self)


def load_scores(directory: Path | None = None) -> tuple[list[Score], list[str]]:
    """The high-score table, best first, without damaged entries; notices saying what was dropped."""
    return _load_scores(_file(directory, "scores.json"))


def add_score(scores: list[Score], score: Score, directory: Path | None = None) -> tuple[list[Score], int | None]:
    """The table with ``score`` in it (saved), and its rank (0 = best) or None if it did not make it.

    OSError if it cannot be saved (nor the damaged file it would replace be kept first).
    """
    table = sorted([*scores, score], key=lambda s: -s.score)[:MAX_SCORES]
    rank = next((i for i, s in enumerate(table) if s is score), None)
    _save(_file(directory, "scores.json"), [asdict(s) for s in table], lambda p: not _load_scores(p)[1])
    return table, rank


def _load_scores(path: Path) -> tuple[list[Score], list[str]]:
    data, problem, kept = _read(path)
    if problem:
        return [], [f"{problem}; starting a new high-score table{kept}"]
    if data is _NO_FILE:
        return [], []
    if not isinstance(data, list):
        return [], [f"{shown(path)}: expected a list of scores, not {_kind(data)}; "
                    f"starting a new high-score table{kept}"]
    scores, dropped = [], []
    for i, entry in enumerate(data, 1):
        problem = _score_problem(entry)
        if problem:
            dropped.append(f"entry {i}: {problem}")
        else:
            scores.append(Score(**{f.name: entry[f.name] for f in fields(Score)}))
    notices = [f"{shown(path)}: {len(dropped)} of {len(data)} entries damaged and dropped "
               f"({dropped[0]}){kept}"] if dropped else []
    return sorted(scores, key=lambda s: -s.score)[:MAX_SCORES], notices


def _score_problem(entry: object) -> str:
    """What is wrong with one entry of scores.json, or ""."""
    if not isinstance(entry, dict):
        return f"expected an object, not {_kind(entry)}"
    missing = [f.name for f in fields(Score) if f.name not in entry]
    if missing:
        return f"it lacks {', '.join(missing)}"
    return "; ".join(_problems(Score, entry).values())


# ----------------------------------------------------------------- files


def _file(directory: Path | None, name: str) -> Path:
    return (directory or config_dir()) / name


def _kind(value: object) -> str:
    return {dict: "an object", list: "a list", str: "text", bool: "true/false", type(None): "null"}.get(
        type(value), _short(value))


_NO_FILE = object()  # what _read gives for a file that is not there (a file may hold null)


def _read(path: Path) -> tuple[object, str, str]:
    """The file's JSON (:data:`_NO_FILE` if there is none), why it cannot be used, and what a save will keep.

    Numbers are read leniently: ``NaN`` or ``1e400`` spoil only their own value.
    The last item is the notice's note that a damaged regular file will be kept
    (:func:`_keep_damaged`); a file that cannot be read or is no regular file
    is never saved over at all.
    """
    kept = f" (a copy is kept as {path.name}.damaged before the game saves over it)"
    try:
        return read_json(path, lenient_numbers=True, source=shown(path)), "", kept
    except FileNotFoundError:
        return _NO_FILE, "", ""
    except JSONInputError as e:
        return None, str(e), kept if path.is_file() else ""
    except OSError as e:
        return None, f"{shown(path)} cannot be read ({e.strerror or e})", ""


def storage_notice(directory: Path | None = None) -> str:
    """Why settings and scores cannot be saved in ``directory`` (default: :func:`config_dir`), or ""."""
    folder = directory or config_dir()
    probe = folder
    try:
        while not probe.exists() and probe.parent != probe:
            probe = probe.parent
        usable = probe.is_dir() and os.access(probe, os.W_OK | os.X_OK)
    except OSError as e:
        return f"{shown(folder)} cannot be used ({e.strerror or e}): settings and high scores will not be saved"
    if usable:
        return ""
    why = "is not a folder" if not probe.is_dir() else "cannot be written"
    return f"{shown(probe)} {why}: settings and high scores will not be saved"


def _save(path: Path, value: object, loads_cleanly: Callable[[Path], bool]) -> None:
    """Write ``value`` as JSON to ``path`` atomically, having kept a damaged file first."""
    path.parent.mkdir(parents=True, exist_ok=True)
    _keep_damaged(path, loads_cleanly)
    atomic_write(path, json.dumps(value, indent=1) + "\n")


def _keep_damaged(path: Path, loads_cleanly: Callable[[Path], bool]) -> None:
    """Before ``path`` is replaced: copy it to ``<name>.damaged`` unless it loads cleanly.

    OSError when it is not a regular file or cannot be copied: then it is not replaced.
    """
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISREG(mode):
        raise OSError(f"{shown(path)} is not a regular file; it is left as it is")
    if loads_cleanly(path):
        return
    data = path.read_bytes()
    for n in range(1, MAX_DAMAGED_COPIES + 1):
        copy = path.with_name(f"{path.name}.damaged" + (f".{n}" if n > 1 else ""))
        try:
            if copy.read_bytes() == data:
                return  # kept already
        except FileNotFoundError:
            with open(copy, "xb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            return
    raise OSError(f"{shown(path)} is damaged and {MAX_DAMAGED_COPIES} damaged copies lie beside it "
                  f"already; it is left as it is")

