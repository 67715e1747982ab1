"""The firmware's portable C (firmware/energyball/src) as a ctypes library, for host tests.

``build_host_library`` compiles it with ``make -C firmware host-lib`` (gcc -Wall
-Wextra -Werror) into a directory of the caller's; the ctypes structures below
mirror the C ones field for field, so ctypes lays them out as the host compiler does.
"""

from __future__ import annotations

import ctypes as C
import shutil
import subprocess
from pathlib import Path

from ..unavailable import unavailable

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / "firmware"


def require(ok: bool, message: str) -> None:
    """Skip unless ``ok``, except under CI (CI=true), which installs everything and must fail."""
    if not ok:
        unavailable(message, "it must be installed (.ci/run)")


def require_tool(tool: str, why: str) -> None:
    require(shutil.which(tool) is not None, f"{tool} is not installed ({why})")


def make(*args: str) -> subprocess.CompletedProcess:
    """``make -C firmware args...``, output captured."""
    return subprocess.run(["make", "-C", str(FIRMWARE), *args], capture_output=True, text=True)


def build_host_library(build_dir: Path) -> C.CDLL:
    require_tool("make", "the firmware is built with make")
    require_tool("gcc", "the firmware's host tests compile its C with gcc")
    r = make("host-lib", f"BUILD_DIR={build_dir}")
    assert r.returncode == 0, f"host build failed:\n{r.stdout}\n{r.stderr}"
    lib = C.CDLL(str(build_dir / "host" / "libenergyball.so"))
    _declare(lib)
    return lib


class Raw(C.Structure):
    _fields_ = [("t_us", C.c_uint32), ("seq", C.c_uint16), ("acc", C.c_int16 * 3),
                ("gyr", C.c_int16 * 3), ("mag", C.c_int16 * 3), ("flex_adc", C.c_uint16),
                ("acc_fs", C.c_uint8), ("gyr_fs", C.c_uint8), ("mag_valid", C.c_bool),
                ("mag_overflow", C.c_bool)]


class Fused(C.Structure):
    _fields_ = [("t_us", C.c_uint32), ("seq", C.c_uint16), ("q", C.c_float * 4),
                ("flex_deg", C.c_float)]


class Hello(C.Structure):
    _fields_ = [("fw_major", C.c_uint8), ("fw_minor", C.c_uint8), ("fw_patch", C.c_uint8),
                ("imu_whoami", C.c_uint8), ("mag_whoami", C.c_uint8), ("rate_hz", C.c_uint16),
                ("mode", C.c_uint8), ("streaming", C.c_uint8), ("acc_fs", C.c_uint8),
                ("gyr_fs", C.c_uint8), ("errors", C.c_uint16)]


class Command(C.Structure):
    _fields_ = [("type", C.c_uint8), ("arg", C.c_uint16)]


class Parser(C.Structure):
    _fields_ = [("buf", C.c_uint8 * 40), ("n", C.c_uint8)]


class State(C.Structure):
    _fields_ = [("rate_hz", C.c_uint16), ("mode", C.c_uint8), ("streaming", C.c_bool),
                ("seq", C.c_uint16), ("raw_sent", C.c_uint16)]


class Reply(C.Structure):
    _fields_ = [("ack", C.c_bool), ("status", C.c_uint8), ("action", C.c_uint8), ("hello", C.c_bool)]


class Grid(C.Structure):
    _fields_ = [("t_us", C.c_uint32), ("step_us", C.c_uint32), ("step_rem", C.c_uint16),
                ("rem", C.c_uint16), ("rate_hz", C.c_uint16)]


class TimerPlan(C.Structure):
    _fields_ = [("prescaler_bits", C.c_uint8), ("us_per_tick_x16", C.c_uint16),
                ("ticks_per_s", C.c_uint32), ("period", C.c_uint16), ("period_rem", C.c_uint16),
                ("acc", C.c_uint16), ("rate_hz", C.c_uint16)]


class Filter(C.Structure):
    _fields_ = [("q", C.c_float * 4), ("alpha", C.c_float), ("levelled", C.c_bool)]


class Mag(C.Structure):
    _fields_ = [("mag", C.c_int16 * 3), ("ready", C.c_bool), ("overflow", C.c_bool)]


class Still(C.Structure):
    _fields_ = [("first", C.c_int16 * 6), ("sum", C.c_int32 * 6), ("sq", C.c_int32 * 6), ("n", C.c_uint8)]


class Rail(C.Structure):
    _fields_ = [("run", C.c_uint16)]


_BYTES = C.POINTER(C.c_uint8)
_SIGNATURES = {
    "eb_crc16": (C.c_uint16, [C.c_char_p, C.c_size_t, C.c_uint16]),
    "eb_encode_raw": (C.c_size_t, [_BYTES, C.POINTER(Raw)]),
    "eb_encode_fused": (C.c_size_t, [_BYTES, C.POINTER(Fused)]),
    "eb_encode_hello": (C.c_size_t, [_BYTES, C.POINTER(Hello)]),
    "eb_encode_ack": (C.c_size_t, [_BYTES, C.c_uint8, C.c_uint8]),
    "eb_encode_temp": (C.c_size_t, [_BYTES, C.c_uint32, C.c_int16]),
    "eb_q14": (C.c_int16, [C.c_float]),
    "eb_centi": (C.c_int16, [C.c_float]),
    "eb_parser_init": (None, [C.POINTER(Parser)]),
    "eb_parser_push": (None, [C.POINTER(Parser), C.c_uint8]),
    "eb_parser_next": (C.c_bool, [C.POINTER(Parser), C.POINTER(Command)]),
    "eb_state_power_up": (None, [C.POINTER(State)]),
    "eb_execute": (Reply, [C.POINTER(State), C.POINTER(Command)]),
    "eb_temp_due": (C.c_bool, [C.POINTER(State)]),
    "eb_count_raw": (None, [C.POINTER(State), C.c_bool]),
    "eb_rail_update": (C.c_bool, [C.POINTER(Rail), C.c_uint16, C.c_uint16]),
    "eb_led_on": (C.c_bool, [C.c_uint8, C.c_uint32]),
    "eb_rate_valid": (C.c_bool, [C.c_uint16, C.c_uint8]),
    "eb_max_rate_hz": (C.c_uint16, [C.c_uint8, C.c_uint32, C.c_uint32, C.c_uint32]),
    "eb_uart_baud": (C.c_uint32, [C.c_uint32, C.c_uint32]),
    "eb_grid_set": (None, [C.POINTER(Grid), C.c_uint16, C.c_uint32]),
    "eb_grid_first_after": (C.c_uint32, [C.c_uint16, C.c_uint32]),
    "eb_grid_advance": (None, [C.POINTER(Grid)]),
    "eb_timer_plan": (None, [C.POINTER(TimerPlan), C.c_uint16, C.c_uint32]),
    "eb_timer_next_period": (C.c_uint16, [C.POINTER(TimerPlan)]),
    "eb_timer_ticks": (C.c_uint16, [C.POINTER(TimerPlan), C.c_uint32]),
    "eb_filter_init": (None, [C.POINTER(Filter), C.c_float]),
    "eb_filter_update": (None, [C.POINTER(Filter), C.POINTER(C.c_float), C.POINTER(C.c_float), C.c_float]),
    "eb_format_text_line": (C.c_size_t, [C.c_char_p, C.POINTER(C.c_float), C.c_float]),
    "eb_imu_known": (C.c_bool, [C.c_uint8]),
    "eb_fs_register": (C.c_uint8, [C.c_uint8]),
    "eb_dlpf_for_rate": (C.c_uint8, [C.c_uint16]),
    "eb_mpu_parse": (None, [C.c_char_p, C.POINTER(C.c_int16), C.POINTER(C.c_int16), C.POINTER(C.c_int16)]),
    "eb_mag_adjust": (C.c_int16, [C.c_int16, C.c_uint8]),
    "eb_ak_parse": (None, [C.c_char_p, C.c_char_p, C.POINTER(Mag)]),
    "eb_flex_deg": (C.c_float, [C.c_float]),
    "eb_flex_rail_seconds": (C.c_uint8, [C.c_uint16]),
    "eb_gyr_unbiased": (C.c_int16, [C.c_int16, C.c_int16]),
    "eb_gyr_rad_s": (C.c_float, [C.c_int16, C.c_uint8]),
    "eb_acc_m_s2": (C.c_float, [C.c_int16, C.c_uint8]),
    "eb_still_init": (None, [C.POINTER(Still)]),
    "eb_still_add": (None, [C.POINTER(Still), C.POINTER(C.c_int16), C.POINTER(C.c_int16)]),
    "eb_still_is_still": (C.c_bool, [C.POINTER(Still)]),
    "eb_still_mean": (None, [C.POINTER(Still), C.POINTER(C.c_int16)]),
    "eb_bias_pack": (None, [C.c_char_p, C.POINTER(C.c_int16)]),
    "eb_bias_unpack": (C.c_bool, [C.c_char_p, C.POINTER(C.c_int16)]),
}


def _declare(lib: C.CDLL) -> None:
    for name, (restype, argtypes) in _SIGNATURES.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes


def frame_buffer(size: int = 64) -> C.Array:
    return (C.c_uint8 * size)()
