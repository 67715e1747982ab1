"""The firmware builds with avr-gcc and the Debian Arduino core, within the 75% budget.

Skipped without the AVR toolchain (apt-get install gcc-avr binutils-avr avr-libc
arduino-core-avr), except under CI=true, where a missing toolchain fails.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from .firmware_lib import FIRMWARE, make, require, require_tool

CORE = Path("/usr/share/arduino/hardware/arduino/avr/cores/arduino/Arduino.h")
ATMEGA328P = {"flash": 32768, "RAM": 2048}  # bytes of each on the chip
SIZE_LINE = re.compile(r"^(?P<name>[\w-]+): (?P<what>flash|RAM) (?P<bytes>\d+) bytes "
                       r"\((?P<percent>[\d.]+)% of (?P<total>\d+), limit (?P<limit>\d+)\)$", re.M)


def require_avr() -> None:
    for tool in ("make", "avr-gcc", "avr-g++", "avr-size", "avr-objcopy"):
        require_tool(tool, "apt-get install gcc-avr binutils-avr avr-libc arduino-core-avr")
    require(CORE.exists(), f"the Arduino core ({CORE}) is not installed: apt-get install arduino-core-avr")


def sizes(output: str) -> dict[str, dict[str, float]]:
    """{"flash" | "RAM": {"bytes", "percent", "total", "limit"}} from the size lines of make."""
    return {m["what"]: {k: float(m[k]) for k in ("bytes", "percent", "total", "limit")}
            for m in SIZE_LINE.finditer(output)}


@pytest.fixture(scope="module")
def build_dir(tmp_path_factory):
    require_avr()
    return tmp_path_factory.mktemp("firmware-avr")


@pytest.mark.parametrize("variant, name", [((), "energyball"), (("LEGACY_TEXT=1",), "energyball-legacy")])
def test_firmware_builds_within_budget(build_dir, variant, name):
    r = make(f"BUILD_DIR={build_dir}", *variant)
    assert r.returncode == 0, f"firmware build failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    assert (build_dir / f"{name}.elf").is_file() and (build_dir / f"{name}.hex").is_file()
    got = sizes(r.stdout)
    assert set(got) == {"flash", "RAM"}, r.stdout[-2000:]
    for what, s in got.items():
        assert s["total"] == ATMEGA328P[what] and s["limit"] == s["total"] * 3 // 4  # the 75% budget
        assert 0 < s["bytes"] <= s["limit"], (what, s)
        assert s["percent"] == pytest.approx(100 * s["bytes"] / s["total"], abs=0.06)
    # the hex starts at the reset vector and is what avrdude would write
    assert (build_dir / f"{name}.hex").read_text().startswith(":100000000C94")


def test_build_fails_above_the_budget(build_dir):
    make(f"BUILD_DIR={build_dir}")
    r = make(f"BUILD_DIR={build_dir}", "FLASH_LIMIT=1000")
    assert r.returncode != 0 and "over the 75% budget" in r.stderr


def test_host_test_builds_the_library_warning_free(tmp_path):
    """make host-test builds the portable C as the host library, warnings as errors (pytest checks it)."""
    require_tool("make", "the firmware is built with make")
    require_tool("gcc", "make host-test compiles the firmware's C for the host")
    r = make(f"BUILD_DIR={tmp_path}", "host-test")
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "host" / "libenergyball.so").is_file()
    assert "-Werror" in r.stdout and "-pedantic" in r.stdout, r.stdout


def test_sketch_documents_its_phase_markers():
    """The cycle-counting harness (firmware/sim) relies on PB0/PB1/PB2 as documented."""
    sketch = (FIRMWARE / "energyball" / "energyball.ino").read_text()
    for pin in ("PB0 (D8)", "PB1 (D9)", "PB2 (D10)"):
        assert pin in sketch and pin in (FIRMWARE / "README.md").read_text()
