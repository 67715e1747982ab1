"""``make -C firmware`` without the AVR toolchain or the Arduino core: one line naming what is missing.

Each case runs the real Makefile with a PATH that lacks the AVR commands (a folder
of links to everything on the PATH but ``avr-*``), or with stand-in AVR commands
(small shell scripts) so that the Arduino core's check is seen on its own, whether or
not this machine has the toolchain. Before the check, make said only "No rule to make
target 'build/obj-energyball/wire/Wire.cpp.o'".
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
from pathlib import Path

import pytest

from .firmware_lib import FIRMWARE, require_tool

GCC_AVR = ("avr-gcc", "avr-g++", "avr-gcc-ar")  # Debian's gcc-avr
BINUTILS_AVR = ("avr-objcopy", "avr-size")  # Debian's binutils-avr


@pytest.fixture(autouse=True)
def _make_installed():
    require_tool("make", "the firmware is built with make")


def path_without_avr(folder: Path) -> str:
    """A PATH of one folder linking every command of the current PATH except the ``avr-*`` ones."""
    folder.mkdir()
    for directory in os.environ.get("PATH", "").split(os.pathsep):
        if not os.path.isdir(directory):
            continue
        for name in os.listdir(directory):
            link = folder / name
            if not name.startswith("avr-") and not link.exists() and not link.is_symlink():
                link.symlink_to(Path(directory) / name)
    return str(folder)


def stand_in(folder: Path, names: tuple[str, ...], exit_code: int = 0) -> None:
    """Shell scripts named like the AVR commands, exiting with ``exit_code``."""
    for name in names:
        script = folder / name
        script.write_text(f"#!/bin/sh\nexit {exit_code}\n")
        script.chmod(script.stat().st_mode | stat.S_IXUSR)


def run_make(path: str, *args: str) -> subprocess.CompletedProcess:
    make = shutil.which("make")
    assert make is not None
    env = {**os.environ, "PATH": path}
    env.pop("ARDUINO_DIR", None)
    env.pop("MAKEFLAGS", None)
    return subprocess.run([make, "-C", str(FIRMWARE), *args], capture_output=True, text=True, env=env)


def one_line(r: subprocess.CompletedProcess) -> str:
    """The single line make stopped with (it must be one, and no "No rule to make target")."""
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert "No rule to make target" not in r.stderr
    return lines[0]


@pytest.mark.parametrize("goal", [(), ("all",), ("size",), ("build/energyball.hex",)])
def test_without_the_avr_toolchain_one_line_names_the_commands_and_packages(tmp_path, goal):
    build = tmp_path / "build"
    line = one_line(run_make(path_without_avr(tmp_path / "bin"), f"BUILD_DIR={build}", *goal))
    assert "cannot build the firmware: missing" in line
    for tool in (*GCC_AVR, *BINUTILS_AVR):
        assert tool in line
    assert "(Debian package gcc-avr)" in line and "(Debian package binutils-avr)" in line
    assert not build.exists()  # stopped before anything was made


def test_only_binutils_missing_names_only_binutils(tmp_path):
    bin_dir = Path(path_without_avr(tmp_path / "bin"))
    stand_in(bin_dir, GCC_AVR)
    line = one_line(run_make(str(bin_dir), f"BUILD_DIR={tmp_path / 'build'}"))
    assert "avr-objcopy, avr-size (Debian package binutils-avr)" in line
    assert "gcc-avr" not in line and "avr-gcc" not in line


@pytest.mark.parametrize("where", ["/nonexistent", "/elsewhere/arduino"])
def test_without_the_arduino_core_at_arduino_dir_one_line_names_it(tmp_path, where):
    bin_dir = Path(path_without_avr(tmp_path / "bin"))
    stand_in(bin_dir, GCC_AVR + BINUTILS_AVR)
    line = one_line(run_make(str(bin_dir), f"BUILD_DIR={tmp_path / 'build'}", f"ARDUINO_DIR={where}"))
    assert f"the Arduino core at ARDUINO_DIR={where}" in line
    assert "(Debian package arduino-core-avr" in line
    assert "gcc-avr" not in line and "binutils-avr" not in line


def test_arduino_dir_from_the_environment_is_checked_too(tmp_path):
    bin_dir = Path(path_without_avr(tmp_path / "bin"))
    stand_in(bin_dir, GCC_AVR + BINUTILS_AVR)
    make = shutil.which("make")
    assert make is not None
    env = {**os.environ, "PATH": str(bin_dir), "ARDUINO_DIR": "/nonexistent"}
    env.pop("MAKEFLAGS", None)
    r = subprocess.run([make, "-C", str(FIRMWARE), f"BUILD_DIR={tmp_path / 'build'}"],
                       capture_output=True, text=True, env=env)
    assert "the Arduino core at ARDUINO_DIR=/nonexistent" in one_line(r)


def test_a_core_without_wire_names_the_missing_files(tmp_path):
    """A folder that has the core but not the Wire library (an incomplete copy)."""
    core = tmp_path / "avr"
    (core / "cores" / "arduino").mkdir(parents=True)
    (core / "cores" / "arduino" / "Arduino.h").write_text("")
    (core / "variants" / "standard").mkdir(parents=True)
    (core / "variants" / "standard" / "pins_arduino.h").write_text("")
    bin_dir = Path(path_without_avr(tmp_path / "bin"))
    stand_in(bin_dir, GCC_AVR + BINUTILS_AVR)
    line = one_line(run_make(str(bin_dir), f"BUILD_DIR={tmp_path / 'build'}", f"ARDUINO_DIR={core}"))
    assert f"the Arduino core's {core}/libraries/Wire/src/Wire.cpp (ARDUINO_DIR={core})" in line
    assert "Arduino.h" not in line and "pins_arduino.h" not in line


def test_a_compiler_without_avr_libc_names_avr_libc(tmp_path):
    bin_dir = Path(path_without_avr(tmp_path / "bin"))
    stand_in(bin_dir, GCC_AVR, exit_code=1)  # the compiler cannot find <avr/io.h>
    stand_in(bin_dir, BINUTILS_AVR)
    line = one_line(run_make(str(bin_dir), f"BUILD_DIR={tmp_path / 'build'}"))
    assert "avr-libc's <avr/io.h> (Debian package avr-libc)" in line


def test_flash_without_avrdude_names_it(tmp_path):
    bin_dir = Path(path_without_avr(tmp_path / "bin"))
    stand_in(bin_dir, GCC_AVR + BINUTILS_AVR)
    line = one_line(run_make(str(bin_dir), f"BUILD_DIR={tmp_path / 'build'}", "flash", "AVRDUDE=no-avrdude-here"))
    assert "no-avrdude-here (Debian package avrdude)" in line


def test_host_goals_need_no_avr_toolchain(tmp_path):
    """host-test and clean build and clean without avr-gcc or the core."""
    require_tool("gcc", "make host-test compiles the firmware's C for the host")
    path = path_without_avr(tmp_path / "bin")
    build = tmp_path / "build"
    r = run_make(path, f"BUILD_DIR={build}", "ARDUINO_DIR=/nonexistent", "host-test")
    assert r.returncode == 0, r.stderr
    assert (build / "host" / "libenergyball.so").is_file()
    r = run_make(path, f"BUILD_DIR={build}", "ARDUINO_DIR=/nonexistent", "clean")
    assert r.returncode == 0, r.stderr
    assert not build.exists()
