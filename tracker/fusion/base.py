"""The interface every fusion filter shares.

A filter turns gyroscope, accelerometer and (optionally) magnetometer samples
into ``q_WS``, the sensor's orientation in the world frame (z up; East-North-Up
when a magnetometer fixes heading, arbitrary heading without one).

Each filter keeps three things apart (after the structure of dlaidig/vqf):
``params`` (a dataclass of documented settings, fixed after construction),
``state`` (a dataclass the filter owns: read it with :meth:`Filter.get_state`,
restore it with :meth:`Filter.set_state`, start over with :meth:`Filter.reset`)
and read-only ``flags`` about the last update (after x-io Fusion's flags).

Bad input never breaks a filter: :meth:`Filter.update` checks each sample
first. A non-finite gyroscope sample is skipped; a non-finite accelerometer or
magnetometer sample is left out of the correction; a sample at the sensor's
full scale is flagged as saturated. The state stays finite either way.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar, Generic, Protocol, Sequence, TypeVar

import numpy as np
from mypy_extensions import mypyc_attr

from .qmath import Quat, Vec

GYR_SATURATION = math.radians(2000) * 0.999  # MPU-9250 at its widest full scale
ACC_SATURATION = 16 * 9.80665 * 0.999
PLAUSIBLE = 100.0  # readings beyond this many full scales are corrupt, not motion
_GYR_LIMIT = GYR_SATURATION * PLAUSIBLE
_ACC_LIMIT = ACC_SATURATION * PLAUSIBLE
_MAG_LIMIT = 1e4  # uT: the Earth's field is about 25-65

Reading = Sequence[float] | np.ndarray  # one 3-axis reading: a tuple, a list or an array


@dataclass(slots=True)
class Flags:
    """What happened in the last update (read-only for callers).

    Each update makes a new Flags, so one kept from an earlier update still
    describes that update.
    """

    skipped: bool = False  # the sample was unusable (non-finite gyroscope or dt)
    acc_ignored: bool = False  # accelerometer unusable (non-finite or zero)
    mag_ignored: bool = False  # magnetometer absent or unusable
    saturated: bool = False  # a reading at the sensor's full scale
    rest: bool = False  # the filter believes the sensor is at rest (where it detects rest)
    acc_rejected: bool = False  # accelerometer judged disturbed and not used (where supported)
    mag_rejected: bool = False  # magnetometer judged disturbed and not used (where supported)
    mag_unusable: bool = False  # magnetometer judged unusable for now (uncalibrated or disturbed; where
    # supported): heading from the gyroscope alone (or nearly) until it proves consistent again


class _HasQuat(Protocol):
    """What every filter state has: the current estimate."""

    q: Quat


if TYPE_CHECKING:
    from _typeshed import DataclassInstance

P = TypeVar("P", bound="DataclassInstance")  # the parameters: a dataclass
S = TypeVar("S", bound=_HasQuat)


@mypyc_attr(allow_interpreted_subclasses=True)  # compiled (setup.py), yet open to new filters
class Filter(ABC, Generic[P, S]):
    """A streaming orientation filter; subclasses implement :meth:`_step`."""

    name: ClassVar[str]
    uses_magnetometer: ClassVar[bool] = True  # False: the filter ignores ``mag`` by design
    Params: ClassVar[type]
    State: ClassVar[type]

    def __init__(self, params: P | None = None, **overrides: object) -> None:
        base = params if params is not None else self.Params()
        for key in overrides:
            if not hasattr(base, key):
                raise ValueError(f"filter {self.name!r} has no parameter {key!r}")
        self.params: P = dataclasses.replace(base, **overrides)
        self.flags = Flags()
        self._state: S = self._initial_state()

    # ------------------------------------------------------------ state

    def _initial_state(self) -> S:
        """The state before the first sample: ``State()`` with its defaults (override if
        the state depends on the parameters)."""
        return self.State()

    def reset(self) -> None:
        """Forget everything learned; the next sample starts afresh."""
        self._state = self._initial_state()
        self.flags = Flags()

    def get_state(self) -> S:
        """A copy of the state (changing it does not change the filter)."""
        return copy.deepcopy(self._state)

    def set_state(self, state: S) -> None:
        """Restore a state from :meth:`get_state`."""
        self._state = copy.deepcopy(state)

    @property
    def quat(self) -> Quat:
        """The current estimate of q_WS."""
        return self._state.q

    # ------------------------------------------------------------ updating

    def update(self, gyr: Reading, acc: Reading | None, mag: Reading | None = None,
               dt: float = 0.005) -> Quat:
        """Take one sample (rad/s, m/s^2, uT, seconds) and return the new q_WS."""
        self.flags = flags = Flags()
        # _finite3 written out for the gyroscope (the one input always present) and the
        # saturation test as chained comparisons: this method runs once per sample.
        if gyr is None:
            flags.skipped = True
            return self._state.q
        gx, gy, gz = float(gyr[0]), float(gyr[1]), float(gyr[2])
        lim = _GYR_LIMIT
        if not (-lim < gx < lim and -lim < gy < lim and -lim < gz < lim  # also NaN
                and 0.0 < dt < 1.0):
            flags.skipped = True
            return self._state.q
        a = _finite3(acc, _ACC_LIMIT)
        if a is None or a == (0.0, 0.0, 0.0):
            flags.acc_ignored, a = True, None
        m = _finite3(mag, _MAG_LIMIT)
        if m is None or m == (0.0, 0.0, 0.0):
            flags.mag_ignored, m = True, None
        # saturated: some |component| at or beyond full scale (all are finite here)
        lim = GYR_SATURATION
        if not (-lim < gx < lim and -lim < gy < lim and -lim < gz < lim):
            flags.saturated = True
        elif a is not None:
            lim = ACC_SATURATION
            flags.saturated = not (-lim < a[0] < lim and -lim < a[1] < lim and -lim < a[2] < lim)
        return self._step((gx, gy, gz), a, m, dt)

    @abstractmethod
    def _step(self, gyr: Vec, acc: Vec | None, mag: Vec | None, dt: float) -> Quat:
        """One update with checked input; sets ``self._state.q`` and returns it."""

    def run(self, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray | None, rate: float) -> np.ndarray:
        """Offline: reset, then update on every row; returns (N, 4) q_WS, scalar first."""
        self.reset()
        dt = 1.0 / rate
        n = len(gyr)
        out = np.empty((n, 4))
        g, a = np.asarray(gyr, float).tolist(), np.asarray(acc, float).tolist()
        m = np.asarray(mag, float).tolist() if mag is not None else [None] * n
        update = self.update
        for i in range(n):
            out[i] = update(g[i], a[i], m[i], dt)
        return out


def _finite3(v: Reading | None, limit: float) -> Vec | None:
    """``v`` as a 3-tuple of floats, or None if absent, not finite or beyond ``limit``."""
    if v is None:
        return None
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    if not (-limit < x < limit and -limit < y < limit and -limit < z < limit):  # also NaN
        return None
    return (x, y, z)


