"""Sound effects and music through pygame.mixer, never in the game's way.

``Audio`` plays the WAVs that ``assets/generate.py`` writes (``<name>.wav`` in the assets
folder).  Everything that can go wrong with sound is turned into silence plus a
human-readable ``notice`` instead of an exception:

* no audio device, no driver, pygame's mixer missing -> the whole object is silent;
* a sound file missing or unreadable -> that one sound is silent;
* ``enabled=False`` -> silent from the start, the mixer is never touched.

The mixer is opened lazily, on the first call that needs it (or ``start()``), so making
an ``Audio`` costs nothing and a game can run headless.  If pygame's mixer is already
open (``pygame.init()`` opens it) it is used as it is and left open by ``close()``.

Effects are throttled: the same sound starts at most ``max_repeats`` times in any
``THROTTLE_WINDOW_S`` (50 ms), so ten zombies hit in one frame make one loud hit, not a
clipped roar.  Looping sounds (the charge hum) play on reserved channels, so a burst of
effects never steals them; the music streams through ``pygame.mixer.music``.

This is one of the few modules allowed to import pygame (ARCHITECTURE.md: only
``game.ui.render``, ``game.ui.app`` and the audio module do), and it does so lazily.
"""

from __future__ import annotations

import math
import os
import random
import re
import time
from collections import deque
from pathlib import Path
from typing import Callable

DEFAULT_ASSETS = Path(__file__).resolve().parents[2] / "assets"
MUSIC = "music"
MIXER_RATE = 22050  # Hz: the rate the assets are made at, so nothing is resampled
MIXER_BUFFER = 512  # samples: ~23 ms of latency at 22050 Hz
EFFECT_CHANNELS = 16
LOOP_CHANNELS = 4  # reserved for loop(): effects never steal them
THROTTLE_WINDOW_S = 0.05
MUSIC_FADE_MS = 400
LOOP_FADE_MS = 80
_NAME = re.compile(r"^[A-Za-z0-9_-]+$")


def clamp01(value: float) -> float:
    """``value`` limited to 0..1 (NaN counts as 0)."""
    value = float(value)
    return 0.0 if math.isnan(value) else min(1.0, max(0.0, value))


class Audio:
    """Effects, loops and music by name; silent (with a ``notice``) whenever sound is impossible."""

    def __init__(self, assets_dir: str | os.PathLike = DEFAULT_ASSETS, volume: float = 0.8,
                 music_volume: float = 0.5, enabled: bool = True, *, max_repeats: int = 3, seed: int = 0,
                 clock: Callable[[], float] = time.monotonic):
        self.assets_dir = Path(assets_dir)
        self.volume = clamp01(volume)
        self.music_volume = clamp01(music_volume)
        self.enabled = bool(enabled)
        self.max_repeats = max(1, int(max_repeats))
        self._rng = random.Random(seed)
        self._clock = clock
        self._notices: list[str] = []
        self._pygame = None
        self._state = "new"  # new -> ready | silent; any -> closed
        self._owns_mixer = False
        self._sounds: dict[str, object | None] = {}  # name -> pygame Sound, or None if it cannot play
        self._variants: dict[str, list[str]] = {}
        self._loops: dict[str, tuple[int, float]] = {}  # name -> (reserved channel index, its own volume)
        self._recent: dict[str, deque[float]] = {}
        self._music_on = False
        self._music_broken = False
        if not self.enabled:
            self._go_silent("sound is off (disabled in the settings)")

    # ---- state -------------------------------------------------------------------------

    @property
    def notice(self) -> str:
        """What went wrong with sound, for the player ('' when all is well)."""
        return "; ".join(self._notices)

    @property
    def notices(self) -> tuple[str, ...]:
        return tuple(self._notices)

    @property
    def silent(self) -> bool:
        """True once it is known that nothing will play (no device, disabled or closed)."""
        return self._state in ("silent", "closed")

    @property
    def music_playing(self) -> bool:
        return self._music_on

    def start(self) -> bool:
        """Open the mixer and load every sound now rather than on first use (loading a
        sound mid-game stalls a frame by tens of milliseconds); True if sound can play."""
        if self._mixer() is None:
            return False
        if self.assets_dir.is_dir():
            for path in sorted(self.assets_dir.glob("*.wav")):
                if path.stem != "music":
                    self._sound(path.stem)
        return True

    def _note(self, message: str) -> None:
        if message not in self._notices:
            self._notices.append(message)

    def _go_silent(self, message: str) -> None:
        self._state = "silent"
        self._note(message)

    def _mixer(self):
        """pygame.mixer, opened on first use; None in silent mode."""
        if self._state == "ready":
            return self._pygame.mixer
        if self._state != "new":
            return None
        try:
            os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
            import pygame
        except ImportError as exc:  # pygame is a dependency, but a broken install must not stop the game
            self._go_silent(f"no sound: pygame could not be imported ({exc})")
            return None
        self._pygame = pygame
        try:
            if not pygame.mixer.get_init():
                pygame.mixer.init(frequency=MIXER_RATE, size=-16, channels=2, buffer=MIXER_BUFFER)
                self._owns_mixer = True
            if not pygame.mixer.get_init():
                raise pygame.error("the mixer did not start")
            pygame.mixer.set_num_channels(max(pygame.mixer.get_num_channels(), EFFECT_CHANNELS + LOOP_CHANNELS))
            pygame.mixer.set_reserved(LOOP_CHANNELS)
        except (pygame.error, OSError, NotImplementedError) as exc:
            self._go_silent(f"no sound: the audio device could not be opened ({exc})")
            return None
        self._state = "ready"
        return pygame.mixer

    def _sound(self, name: str):
        """The loaded Sound for ``name`` (cached), or None if it cannot play."""
        if name in self._sounds:
            return self._sounds[name]
        mixer = self._mixer()
        if mixer is None:
            return None
        sound = None
        path = self.assets_dir / f"{name}.wav"
        if not _NAME.match(name):
            self._note(f"no sound called {name!r} (names are letters, digits, _ and -)")
        elif not path.is_file():
            self._note(f"sound {name!r} is missing ({path}); run `python assets/generate.py`")
        else:
            try:
                sound = mixer.Sound(str(path))
                if sound.get_length() <= 0.0:
                    raise ValueError("no samples")
            except (self._pygame.error, OSError, EOFError, ValueError) as exc:
                self._note(f"sound {name!r} could not be loaded from {path} ({exc}); it stays silent")
                sound = None
        self._sounds[name] = sound
        return sound

    def _allow(self, name: str) -> bool:
        """Throttle: True if ``name`` has started fewer than max_repeats times in the window."""
        now = self._clock()
        recent = self._recent.setdefault(name, deque())
        while recent and now - recent[0] >= THROTTLE_WINDOW_S:
            recent.popleft()
        if len(recent) >= self.max_repeats:
            return False
        recent.append(now)
        return True

    # ---- effects -----------------------------------------------------------------------

    def play(self, name: str, volume: float = 1.0) -> bool:
        """Start the effect ``name`` at ``volume`` (x the master volume); True if it started."""
        sound = self._sound(name)
        if sound is None or not self._allow(name):
            return False
        channel = self._pygame.mixer.find_channel(True)  # the oldest effect gives way if all are busy
        if channel is None:
            return False
        channel.set_volume(self.volume * clamp01(volume))
        channel.play(sound)
        return True

    def variants(self, prefix: str) -> list[str]:
        """The sounds named ``<prefix>_<number>`` in the assets folder, in number order."""
        if prefix not in self._variants:
            pattern = re.compile(rf"^{re.escape(prefix)}_(\d+)\.wav$")
            found = []
            if self.assets_dir.is_dir():
                found = sorted((int(m.group(1)), m.group(0)[:-4]) for p in self.assets_dir.iterdir()
                               if (m := pattern.match(p.name)))
            self._variants[prefix] = [name for _, name in found]
            if not found:
                self._note(f"no sounds called {prefix}_1, {prefix}_2, ... in {self.assets_dir}")
        return self._variants[prefix]

    def play_variant(self, prefix: str, volume: float = 1.0) -> str | None:
        """Play one of ``<prefix>_1..N`` picked by the seeded generator; the name if it started."""
        names = self.variants(prefix)
        if not names:
            return None
        name = self._rng.choice(names)
        return name if self.play(name, volume) else None

    # ---- loops -------------------------------------------------------------------------

    def loop(self, name: str, volume: float = 1.0) -> bool:
        """Loop ``name`` until ``stop_loop(name)``; calling again only changes its volume."""
        volume = clamp01(volume)
        if name in self._loops:
            index, _ = self._loops[name]
            channel = self._pygame.mixer.Channel(index)
            if channel.get_busy():
                channel.set_volume(self.volume * volume)
                self._loops[name] = (index, volume)
                return True
            del self._loops[name]
        sound = self._sound(name)
        if sound is None:
            return False
        mixer = self._pygame.mixer
        untaken = [i for i in range(LOOP_CHANNELS) if i not in {i for i, _ in self._loops.values()}]
        if not untaken:
            self._note(f"too many loops at once; {name!r} not started")
            return False
        index = next((i for i in untaken if not mixer.Channel(i).get_busy()), untaken[0])  # else cut a fade short
        channel = mixer.Channel(index)
        channel.set_volume(self.volume * volume)
        channel.play(sound, loops=-1)
        self._loops[name] = (index, volume)
        return True

    def stop_loop(self, name: str, fade_ms: int = LOOP_FADE_MS) -> None:
        """Stop the loop ``name`` (a short fade avoids a click); no-op if it is not looping."""
        entry = self._loops.pop(name, None)
        if entry is None or self._state != "ready":
            return
        channel = self._pygame.mixer.Channel(entry[0])
        if fade_ms > 0:
            channel.fadeout(int(fade_ms))
        else:
            channel.stop()

    def stop_loops(self) -> None:
        for name in list(self._loops):
            self.stop_loop(name)

    @property
    def looping(self) -> tuple[str, ...]:
        return tuple(self._loops)

    # ---- music -------------------------------------------------------------------------

    def music(self, on: bool) -> bool:
        """Start (looping forever) or stop the background music; True if it is now playing."""
        if not on:
            if self._music_on and self._state == "ready":
                self._pygame.mixer.music.fadeout(MUSIC_FADE_MS)
            self._music_on = False
            return False
        if self._music_on:
            return True
        mixer = self._mixer()
        if mixer is None or self._music_broken:
            return False
        path = self.assets_dir / f"{MUSIC}.wav"
        try:
            if not path.is_file():
                raise FileNotFoundError(f"{path} is missing; run `python assets/generate.py`")
            mixer.music.load(str(path))
            mixer.music.set_volume(self.music_volume)
            mixer.music.play(loops=-1)
        except (self._pygame.error, OSError) as exc:
            self._music_broken = True
            self._note(f"no music ({exc})")
            return False
        self._music_on = True
        return True

    # ---- volume and shutdown -----------------------------------------------------------

    def set_volume(self, volume: float) -> float:
        """Master volume for effects and loops, clamped to 0..1 (running loops follow)."""
        self.volume = clamp01(volume)
        if self._state == "ready":
            for index, own in self._loops.values():
                self._pygame.mixer.Channel(index).set_volume(self.volume * own)
        return self.volume

    def set_music_volume(self, volume: float) -> float:
        """Music volume, clamped to 0..1."""
        self.music_volume = clamp01(volume)
        if self._state == "ready":
            self._pygame.mixer.music.set_volume(self.music_volume)
        return self.music_volume

    def close(self) -> None:
        """Stop everything; close the mixer if this object opened it. Safe to call twice."""
        if self._state == "ready":
            mixer = self._pygame.mixer
            try:
                for index, _ in self._loops.values():
                    mixer.Channel(index).stop()
                mixer.music.stop()
                mixer.stop()
                if self._owns_mixer:
                    mixer.quit()
            except self._pygame.error as exc:  # the device vanished under us: nothing left to stop
                self._note(f"sound closed with an error ({exc})")
        self._loops.clear()
        self._sounds.clear()
        self._music_on = False
        self._owns_mixer = False
        self._state = "closed"

    def __enter__(self) -> "Audio":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
