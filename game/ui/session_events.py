"""The window's side of a session recording: input events to JSON and back, the header, the summary.

Only the events the game reads are kept (keys, mouse buttons and motion,
resizes, quit), with the fields it reads, so a replay hands the game the
same events. The header holds what a replay needs to start the same game:
the versions, the seed, the settings, the window's size, the input chosen
and the board calibrations saved on this computer (read again when a
board says who it is).
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import pygame

from tracker import protocol as P
from tracker.calibration import boards_dir
from tracker.userjson import read_json

from ..replay.log import SessionLog, SessionRecorder
from .preferences import shown

if TYPE_CHECKING:
    from .app import Game

RECORDED = {pygame.KEYDOWN: "keydown", pygame.KEYUP: "keyup", pygame.MOUSEBUTTONDOWN: "mousebuttondown",
            pygame.MOUSEBUTTONUP: "mousebuttonup", pygame.MOUSEMOTION: "mousemotion",
            pygame.VIDEORESIZE: "videoresize", pygame.QUIT: "quit"}
_TYPES = {name: kind for kind, name in RECORDED.items()}
_FIELDS = {"keydown": ("key", "mod", "unicode"), "keyup": ("key", "mod", "unicode"),
           "mousebuttondown": ("button", "pos"), "mousebuttonup": ("button", "pos"),
           "mousemotion": ("pos",), "videoresize": ("size",), "quit": ()}
MAX_BOARD_FILE_BYTES = 64 * 2**10


def event_json(event: pygame.event.Event) -> dict:
    """A recorded event as JSON: its type's name and the fields the game reads."""
    name = RECORDED[event.type]
    out: dict = {"e": name}
    for key in _FIELDS[name]:
        value = getattr(event, key, None)
        out[key] = list(value) if isinstance(value, tuple) else value
    return out


def event_from_json(d: dict) -> pygame.event.Event:
    """The event :func:`event_json` made; a ValueError if ``d`` is not one."""
    name = d.get("e") if isinstance(d, dict) else None
    if name not in _TYPES:
        raise ValueError(f"not a recorded input event: {json.dumps(d)[:80]}")
    fields = {key: tuple(d[key]) if isinstance(d.get(key), list) else d.get(key) for key in _FIELDS[name]}
    return pygame.event.Event(_TYPES[name], **fields)


def game_version() -> str:
    try:
        return metadata.version("energyball")
    except metadata.PackageNotFoundError:  # run from a source tree that was never installed
        return "unknown"


def saved_boards(folder: Path) -> dict[str, dict]:
    """The board calibrations saved in ``folder`` (name: JSON), those that read as JSON."""
    boards: dict[str, dict] = {}
    for path in sorted(folder.glob("*.json")) if folder.is_dir() else []:
        try:
            if path.stat().st_size <= MAX_BOARD_FILE_BYTES:
                boards[path.name] = read_json(path)  # the project's reader: regular files, checked JSON
        except (OSError, ValueError):
            continue  # the game will say what is wrong with it when it reads it
    return boards


def session_header(game: "Game", input_choice: str) -> dict:
    """What a replay needs to start the same game."""
    return {"created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "game_version": game_version(),
            "protocol_version": P.PROTOCOL_VERSION, "seed": game.seed, "window": list(game.window),
            "input": input_choice, "settings": asdict(game.prefs),
            "boards": saved_boards(game.boards_folder() or boards_dir())}


def recorder(path: Path) -> Callable[["Game"], SessionLog]:
    """The App's ``session`` that records to ``path``."""
    return lambda game: SessionRecorder(path, session_header(game, game.prefs.input))


def recordings_dir() -> Path:
    """Where the newest sessions are kept: ``$XDG_DATA_HOME/energyball/recordings`` (``~/.local/share/...``)."""
    base = os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share"
    return Path(base) / "energyball" / "recordings"


def keep_session(game: "Game") -> SessionLog | None:
    """The App's ``session`` of a game played: recorded in :func:`recordings_dir`, keeping the newest
    ``keep_sessions`` (the settings); None when that is 0 or the folder cannot be written (a notice)."""
    keep = game.prefs.keep_sessions
    if keep == 0:
        return None
    folder = recordings_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        kept = sorted(folder.glob("session-*.ebs"), key=lambda p: p.stat().st_mtime)
        for old in kept[:max(0, len(kept) - (keep - 1))]:  # room for this one
            old.unlink()
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = next(p for k in range(1, 1000)
                    if not (p := folder / f"session-{stamp}{'' if k == 1 else f'-{k}'}.ebs").exists())
        return SessionRecorder(path, session_header(game, game.prefs.input))
    except OSError as e:
        game.notices.append(f"this session is not kept ({shown(folder)}: {e.strerror or e})")
        return None


def session_summary(game: "Game") -> dict:
    """How the session ended: the round's score, kills, wave and health."""
    arena = game.arena
    return {"score": arena.score, "kills": arena.kills, "wave": arena.wave, "health": arena.player.health,
            "game_over": arena.game_over}
