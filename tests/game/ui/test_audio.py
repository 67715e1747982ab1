"""Generated sounds (assets/generate.py) and the Audio wrapper (game/ui/audio.py) on SDL's dummy driver."""

import os

os.environ["SDL_AUDIODRIVER"] = "dummy"  # before pygame is imported: no sound card needed
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import importlib.util  # noqa: E402
import io  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import wave  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402

from game.ui.audio import THROTTLE_WINDOW_S, Audio, clamp01  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
ASSETS = ROOT / "assets"
GENERATOR = ASSETS / "generate.py"
RATE = 22050

# What the game expects, written down independently of the generator's own table: seconds (min, max).
EXPECTED = {
    "launch": (0.3, 1.2), "hit": (0.3, 1.2), "miss": (0.2, 1.0), "wall": (0.2, 0.8), "hurt": (0.2, 1.0),
    "click": (0.01, 0.15),
    "wave": (1.0, 4.0), "game_over": (1.0, 4.0),
    "groan_1": (0.6, 2.5), "groan_2": (0.6, 2.5), "groan_3": (0.6, 2.5),
    "charge_1": (0.9, 1.1), "charge_2": (0.9, 1.1), "charge_3": (0.9, 1.1),
    "music": (20.0, 30.0),
}
LOOPS = ("charge_1", "charge_2", "charge_3", "music")
ONE_SHOTS = tuple(n for n in EXPECTED if n not in LOOPS)


def load_generator():
    spec = importlib.util.spec_from_file_location("energyball_assets_generate", GENERATOR)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while it executes
    spec.loader.exec_module(module)
    return module


gen = load_generator()


def pcm(data: bytes):
    """The WAV's parameters and its samples as floats in [-1, 1]."""
    with wave.open(io.BytesIO(data), "rb") as w:
        params = w.getparams()
        frames = w.readframes(w.getnframes())
    return params, np.frombuffer(frames, "<i2").astype(float) / 32767.0


def samples_of(seconds: float) -> int:
    return int(seconds * RATE)


@pytest.fixture(scope="module")
def rendered():
    """Every sound's WAV bytes, rendered in this process."""
    return {s.name: gen.build(s) for s in gen.SOUNDS}


# ---------------------------------------------------------------------------------------
# The generator and its files
# ---------------------------------------------------------------------------------------

def test_generator_makes_exactly_the_expected_sounds():
    assert sorted(s.name for s in gen.SOUNDS) == sorted(EXPECTED)
    assert {s.name for s in gen.SOUNDS if s.loop} == set(LOOPS)


def test_two_runs_write_identical_bytes(tmp_path, rendered):
    assert gen.main(["--out", str(tmp_path), "--json"]) == 0
    written = {p.stem: p.read_bytes() for p in tmp_path.glob("*.wav")}
    assert written == rendered  # a second, independent render: same bytes
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"{n}.wav" for n in EXPECTED)  # no temp files left


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_sound_is_a_sane_wav(rendered, name):
    params, x = pcm(rendered[name])
    assert (params.nchannels, params.sampwidth, params.framerate, params.comptype) == (1, 2, RATE, "NONE")
    low, high = EXPECTED[name]
    assert low <= len(x) / RATE <= high
    assert np.sqrt(np.mean(x ** 2)) > 0.03, "too quiet / silent"
    assert np.max(np.abs(x)) <= 0.98, "no headroom: clipped or about to clip"
    assert abs(np.mean(x)) < 0.01, "DC offset"


@pytest.mark.parametrize("name", ONE_SHOTS)
def test_one_shots_start_and_end_in_silence(rendered, name):
    _, x = pcm(rendered[name])
    assert abs(x[0]) < 0.01 and abs(x[-1]) < 0.01
    assert np.sqrt(np.mean(x[-samples_of(0.01):] ** 2)) < 0.05  # faded out, no click when it stops


@pytest.mark.parametrize("name", LOOPS)
def test_loops_join_seamlessly(rendered, name):
    """The step from the last sample back to the first is an ordinary step, not a click."""
    _, x = pcm(rendered[name])
    steps = np.abs(np.diff(x))
    assert abs(x[0] - x[-1]) <= np.percentile(steps, 99.0)
    bends = np.abs(np.diff(x, 2))  # and no kink: the slope carries on across the seam too
    assert abs(x[1] - 2 * x[0] + x[-1]) <= np.percentile(bends, 99.0)
    assert abs(x[0] - 2 * x[-1] + x[-2]) <= np.percentile(bends, 99.0)


def test_music_is_a_loop_of_whole_bars_near_100_bpm(rendered):
    _, x = pcm(rendered["music"])
    beats = len(x) / RATE / 0.6  # 100 bpm
    assert beats == pytest.approx(round(beats)) and round(beats) % 4 == 0


def test_charge_variants_rise_in_pitch_and_sizzle(rendered):
    """charge_1..3 stand for low/mid/high charge: more energy up high as the charge grows."""
    shares = []
    for name in ("charge_1", "charge_2", "charge_3"):
        _, x = pcm(rendered[name])
        power = np.abs(np.fft.rfft(x)) ** 2
        freqs = np.fft.rfftfreq(len(x), 1.0 / RATE)
        shares.append(power[freqs > 1000.0].sum() / power.sum())
    assert shares == sorted(shares) and shares[0] < shares[-1]


def test_assets_fit_in_a_commit():
    total = sum(p.stat().st_size for p in ASSETS.glob("*.wav"))
    assert 0 < total < 3_000_000


def test_assets_readme_describes_every_file():
    readme = (ASSETS / "README.md").read_text()
    for name in EXPECTED:
        assert f"{name}.wav" in readme
    assert "python assets/generate.py" in readme and "CC0" in readme


def test_check_passes_on_the_files_in_the_repo():
    done = subprocess.run([sys.executable, str(GENERATOR), "--check"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"{len(EXPECTED)}/{len(EXPECTED)} files match" in done.stdout


def test_check_fails_on_a_changed_or_missing_file(tmp_path, capsys):
    assert gen.main(["--out", str(tmp_path), "--only", "click", "hurt"]) == 0
    assert gen.main(["--out", str(tmp_path), "--only", "click", "hurt", "--check"]) == 0
    data = bytearray((tmp_path / "click.wav").read_bytes())
    data[200] ^= 1
    (tmp_path / "click.wav").write_bytes(bytes(data))
    (tmp_path / "hurt.wav").unlink()
    capsys.readouterr()
    assert gen.main(["--out", str(tmp_path), "--only", "click", "hurt", "--check"]) == 1
    out = capsys.readouterr().out
    assert "differs" in out and "missing" in out


def test_unknown_sound_name_is_a_usage_error(tmp_path):
    with pytest.raises(SystemExit) as stop:
        gen.main(["--out", str(tmp_path), "--only", "kazoo"])
    assert stop.value.code == 2


# ---------------------------------------------------------------------------------------
# Audio
# ---------------------------------------------------------------------------------------

class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


@pytest.fixture
def broken_assets(tmp_path):
    """A copy of the assets with hit.wav garbage, miss.wav missing, hurt.wav empty and music.wav cut short."""
    for p in ASSETS.glob("*.wav"):
        shutil.copy(p, tmp_path / p.name)
    (tmp_path / "hit.wav").write_bytes(b"this is not a wave file" * 40)
    (tmp_path / "miss.wav").unlink()
    with wave.open(str(tmp_path / "hurt.wav"), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(RATE)
        w.writeframes(b"")
    (tmp_path / "music.wav").write_bytes((ASSETS / "music.wav").read_bytes()[:30])
    return tmp_path


def test_audio_plays_everything_on_the_dummy_driver():
    with Audio(ASSETS, clock=FakeClock()) as audio:
        assert audio.start() and not audio.silent
        for name in ONE_SHOTS:
            assert audio.play(name), name
        assert audio.play_variant("groan") in {"groan_1", "groan_2", "groan_3"}
        assert audio.variants("groan") == ["groan_1", "groan_2", "groan_3"]
        for name in ("charge_1", "charge_2", "charge_3"):
            assert audio.loop(name, 0.7)
        assert audio.loop("charge_2", 0.3)  # again: only its volume changes
        assert audio.looping == ("charge_1", "charge_2", "charge_3")
        audio.stop_loop("charge_1")
        audio.stop_loop("charge_1")  # not looping any more: no-op
        audio.stop_loops()
        assert audio.looping == ()
        assert audio.music(True) and audio.music_playing and pygame.mixer.music.get_busy()
        assert audio.music(True)  # already on
        assert not audio.music(False) and not audio.music_playing
        assert audio.notice == ""
    assert audio.silent and not audio.play("click")  # closed: silent, no error


def test_volumes_are_clamped():
    with Audio(ASSETS, volume=3.0, music_volume=-1.0) as audio:
        assert (audio.volume, audio.music_volume) == (1.0, 0.0)
        assert audio.set_volume(0.25) == 0.25 and audio.set_volume(7) == 1.0 and audio.set_volume(-2) == 0.0
        assert audio.set_music_volume(float("nan")) == 0.0 and audio.set_music_volume(0.6) == 0.6
        audio.music(True)
        assert pygame.mixer.music.get_volume() == pytest.approx(0.6, abs=0.01)
    assert clamp01(0.5) == 0.5


def test_throttle_limits_repeats_within_50_ms():
    clock = FakeClock()
    with Audio(ASSETS, max_repeats=2, clock=clock) as audio:
        assert [audio.play("click") for _ in range(3)] == [True, True, False]
        assert audio.play("hit")  # another sound has its own budget
        clock.now += THROTTLE_WINDOW_S * 0.9
        assert not audio.play("click")
        clock.now += THROTTLE_WINDOW_S * 0.2
        assert audio.play("click")


def test_variants_follow_the_seed():
    def picks(seed):
        clock = FakeClock()
        with Audio(ASSETS, seed=seed, clock=clock) as audio:
            names = []
            for _ in range(12):
                clock.now += 1.0
                names.append(audio.play_variant("groan"))
            return names
    assert picks(7) == picks(7)
    assert set(picks(7)) == {"groan_1", "groan_2", "groan_3"}


def test_broken_files_are_silent_with_a_notice(broken_assets):
    with Audio(broken_assets) as audio:
        assert not audio.play("hit") and not audio.play("hit")
        assert not audio.play("miss")
        assert not audio.play("hurt")
        assert not audio.loop("nonexistent")
        assert not audio.play("../music")
        assert not audio.music(True)
        assert audio.play("click") and audio.loop("charge_1")  # the rest still works
        assert not audio.silent
        notice = audio.notice
        for bit in ("'hit' could not be loaded", "'miss' is missing", "'hurt' could not be loaded", "no music",
                    "'../music'"):
            assert bit in notice
        assert notice.count("'hit'") == 1  # said once, not every time it is asked for
        assert audio.play_variant("scream") is None and "scream_1" in audio.notice


def test_mixer_init_failure_means_silence_not_an_exception(monkeypatch):
    def no_device(*args, **kwargs):
        raise pygame.error("No available audio device")
    monkeypatch.setattr(pygame.mixer, "get_init", lambda: None)
    monkeypatch.setattr(pygame.mixer, "init", no_device)
    audio = Audio(ASSETS)
    assert audio.notice == ""  # lazy: nothing tried yet
    assert not audio.play("hit")
    assert audio.silent and "audio device could not be opened" in audio.notice
    assert "No available audio device" in audio.notice
    assert audio.play_variant("groan") is None
    assert not audio.loop("charge_1")
    audio.stop_loop("charge_1")
    assert not audio.music(True) and not audio.music(False)
    assert audio.set_volume(0.3) == 0.3 and audio.set_music_volume(2) == 1.0
    assert not audio.start()
    audio.close()
    audio.close()


def test_disabled_never_touches_the_mixer(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("mixer opened although sound is disabled")
    monkeypatch.setattr(pygame.mixer, "init", forbidden)
    monkeypatch.setattr(pygame.mixer, "get_init", forbidden)
    with Audio(ASSETS, enabled=False) as audio:
        assert audio.silent and "disabled" in audio.notice
        assert not audio.play("hit") and not audio.music(True) and not audio.loop("charge_1")


def test_no_audio_driver_at_all_is_silent():
    """A real failure, no monkeypatching: SDL asked for a driver that does not exist."""
    script = ("from game.ui.audio import Audio\n"
              "a = Audio()\n"
              "print(a.play('hit'), a.music(True), a.silent)\n"
              "print(a.notice)\n"
              "a.close()\n")
    env = dict(os.environ, SDL_AUDIODRIVER="no_such_driver", PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=ROOT,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    first, notice = done.stdout.splitlines()[:2]
    assert first == "False False True"
    assert "audio device could not be opened" in notice
