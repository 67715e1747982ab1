"""Magnetometer calibration: the board's hard iron and soft iron from readings in many orientations.

What a magnetometer on a board reads (NXP AN4246, T. Ozyagcilar, "Calibrating
an eCompass in the presence of hard- and soft-iron interference", rev. 4,
2015, sec. 2; Renaudin, Afzal and Lachapelle, "Complete triaxis magnetometer
calibration in the magnetic domain", Journal of Sensors 2010, 967245, sec. 2;
the model :class:`tracker.sim.MagneticErrors` simulates)::

    m = S R^T h_E + b + noise,

the earth's field h_E turned into the sensor frame, distorted by the soft
iron S and offset by the hard iron b. With W = S^-1 the calibrated field
W (m - b) = R^T h_E has the same strength B in every orientation, so the
readings lie on the ellipsoid

    (m - b)^T A (m - b) = 1,    A = W^T W / B^2,                       (1)

(AN4246 sec. 4; Vasconcelos, Elkaim, Silvestre, Oliveira and Cardeira,
"Geometric approach to strapdown magnetometer calibration in sensor frame",
IEEE Trans. Aerospace and Electronic Systems 47(2), 2011, sec. II, eq. 5-7).
A fit of that ellipsoid to readings taken in many orientations gives b and A;
only W^T W is observable, so W is taken symmetric (AN4246 sec. 5, "Imposing a
symmetric constraint onto the inverse soft-iron matrix": any rotation left in
W turns the whole field and belongs to the sensor's alignment, not to its
soft iron) and normalised to unit determinant, so that the soft iron neither
adds nor removes strength on the whole and B is the field strength seen
through it.

- :func:`fit_sphere`: hard iron only (W = I), the four-parameter linear least
  squares of AN4246 sec. 6 ("Full solution for four parameter calibration"):
  |m - b|^2 = B^2 is linear in (b, B^2 - |b|^2).
- :func:`fit_ellipsoid`: hard iron and symmetric soft iron, the ellipsoid-
  specific least squares of Q. Li and J. G. Griffiths, "Least squares
  ellipsoid specific fitting", Proc. Geometric Modeling and Processing 2004,
  sec. 3 (eq. 11-15), falling back to the sphere when the readings are too
  thin to hold an ellipsoid's nine parameters.
- :func:`coverage`: the share of the sphere of directions the readings
  visited, for refusing a fit from too few orientations.
- :class:`OnlineMagFit`: a bounded collector for a filter that learns the
  calibration in play: plain floats per sample, a fit in numpy now and then.

Units: microtesla throughout. The earth's field at its surface is 22-67 uT
(NOAA/BGS, "The US/UK World Magnetic Model for 2020-2025", technical report,
2020, sec. 4: total intensity F), hence :data:`FIELD_MIN_UT` and
:data:`FIELD_MAX_UT` with room for 20 % of soft iron (the range of
``mag_soft_iron_pct`` in the player profile; :class:`tracker.sim.MagneticErrors`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]

SPHERE = "sphere"
ELLIPSOID = "ellipsoid"
SPHERE_MIN_READINGS = 4  # the sphere's four parameters
ELLIPSOID_MIN_READINGS = 10  # the quadric's ten coefficients, up to scale: nine
MIN_COVERAGE = 0.5  # share of the direction bins a fit needs (see coverage())
ELLIPSOID_COVERAGE = 0.7  # below it the soft iron is not fitted (fit_ellipsoid)
EARTH_MIN_UT = 22.0  # the weakest total intensity at the earth's surface (WMM 2020, sec. 4)
EARTH_MAX_UT = 67.0  # the strongest
FIELD_MIN_UT = 15.0  # the earth's 22 uT (WMM 2020) through 20 % of soft iron, and a margin
FIELD_MAX_UT = 90.0  # the earth's 67 uT (WMM 2020) through 20 % of soft iron, and a margin
MAX_RESIDUAL = 0.05  # a fit whose residual exceeds this share of B is inconsistent (OnlineMagFit)

# The direction bins of coverage(): a zonal equal-area partition of the sphere
# (polar caps, then rings cut into sectors; E. B. Saff and A. B. J. Kuijlaars,
# "Distributing many points on a sphere", Math. Intelligencer 19, 1997, and
# P. Leopardi, "A partition of the unit sphere into regions of equal area and
# small diameter", ETNA 25, 2006, sec. 3). A ring between heights z1 > z2 has
# area 2 pi (z1 - z2) (Archimedes), so cutting z at 1 - 2 c / 40, c the
# cumulative count of bins, makes every bin 4 pi / 40 steradians (about 32
# deg across).
_RING_BINS = (1, 7, 12, 12, 7, 1)
BINS = sum(_RING_BINS)
_RING_FIRST = np.cumsum((0,) + _RING_BINS[:-1])
_RING_TOPS = 1.0 - 2.0 * np.cumsum(_RING_BINS[:-1]) / BINS  # descending: 0.95, 0.6, 0, -0.6, -0.95
_RING_TWIST = (0.0, 0.5, 0.0, 0.5, 0.0, 0.0)  # alternate rings' sectors staggered by half a sector


def _bins_frame() -> Array:
    """The bins' axes (rows): the sensor frame turned by a fixed rotation of 1 rad about
    (0.3, 0.5, 0.8), so that no sensor axis, and no circle that a board turned about one
    of them traces, runs along a ring's edge (Rodrigues' formula)."""
    k = np.array([0.3, 0.5, 0.8]) / math.sqrt(0.98)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    frame: Array = np.eye(3) + math.sin(1.0) * kx + (1.0 - math.cos(1.0)) * (kx @ kx)
    return frame


_BINS_FRAME = _bins_frame()


class MagFitError(ValueError):
    """The readings cannot give a calibration; the message says why, in one line."""


@dataclass(frozen=True)
class MagFit:
    """A magnetometer calibration: calibrated = ``soft_iron`` (m - ``offset``) (:mod:`tracker.magfit`).

    ``soft_iron`` is W, symmetric positive definite with det W = 1 (rows);
    ``field_ut`` the strength B of the calibrated field; ``residual_ut`` the
    RMS of |W (m - b)| - B over the readings fitted; ``coverage`` the share of
    direction bins their calibrated directions hit (:func:`coverage`);
    ``model`` :data:`SPHERE` or :data:`ELLIPSOID`. ``offset`` and ``soft_iron``
    are :class:`tracker.calibration.BoardCalibration`'s ``mag_hard_iron`` and
    ``mag_soft_iron``.
    """

    offset: Vec3
    soft_iron: Mat3
    field_ut: float
    residual_ut: float
    coverage: float
    readings: int
    model: str

    @property
    def relative_residual(self) -> float:
        """The residual as a share of the field strength."""
        return self.residual_ut / self.field_ut

    def correct(self, m: Vec3) -> Vec3:
        """One reading calibrated, plain floats (a filter's per-sample path)."""
        x, y, z = m[0] - self.offset[0], m[1] - self.offset[1], m[2] - self.offset[2]
        (a, b, c), (d, e, f), (g, h, i) = self.soft_iron
        return (a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z)

    def calibrate(self, m: ArrayLike) -> Array:
        """Readings (..., 3) calibrated, W (m - b)."""
        calibrated: Array = (np.asarray(m, dtype=np.float64) - np.array(self.offset)) @ np.array(self.soft_iron).T
        return calibrated


def _readings(m: ArrayLike, least: int) -> Array:
    """``m`` as finite (N, 3) readings, N >= ``least``; a clear one-line error otherwise."""
    try:
        x = np.asarray(m, dtype=np.float64)
    except (TypeError, ValueError):
        raise MagFitError("magnetometer readings must be numbers in rows of three (uT)") from None
    if x.ndim != 2 or x.shape[1] != 3:
        raise MagFitError(f"magnetometer readings must be rows of three (uT), not an array of shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise MagFitError("magnetometer readings must be finite numbers (uT)")
    if len(x) < least:
        raise MagFitError(f"{len(x)} magnetometer readings are too few to fit; at least {least} are needed")
    return x


def bin_index(directions: Array) -> NDArray[np.int64]:
    """The equal-area bin (0 .. BINS - 1) of each nonzero direction (N, 3) (see :func:`coverage`)."""
    v: Array = directions @ _BINS_FRAME.T
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    ring = np.sum(v[:, 2:3] < _RING_TOPS, axis=1)
    count = np.asarray(_RING_BINS)[ring]
    turn = (np.arctan2(v[:, 1], v[:, 0]) / (2.0 * math.pi)) % 1.0
    sector = np.floor(turn * count + np.asarray(_RING_TWIST)[ring]).astype(np.int64) % count
    return np.asarray(_RING_FIRST[ring] + sector, dtype=np.int64)


def bin_directions() -> Array:
    """The centres of the :data:`BINS` direction bins, (BINS, 3) unit vectors in bin order.

    A bin of a ring between heights z1 > z2 spans its sector's azimuths, so its
    centre (of area: the ring is equal-area in z) sits at height (z1 + z2) / 2
    and the sector's middle azimuth, in the bins' frame; the polar caps' at the
    poles. For drawing the sphere of directions a procedure has covered.
    """
    tops = np.concatenate([[1.0], _RING_TOPS])
    bottoms = np.concatenate([_RING_TOPS, [-1.0]])
    rows = []
    for ring, count in enumerate(_RING_BINS):
        z = 0.5 * (tops[ring] + bottoms[ring]) if count > 1 else math.copysign(1.0, tops[ring])
        r = math.sqrt(max(0.0, 1.0 - z * z))
        for sector in range(count):
            turn = 2.0 * math.pi * (sector + 0.5 - _RING_TWIST[ring]) / count
            rows.append((r * math.cos(turn), r * math.sin(turn), z))
    centres: Array = np.array(rows) @ _BINS_FRAME
    return centres


def coverage(directions: ArrayLike) -> float:
    """The share of the sphere of directions that ``directions`` (N, 3) visit: the fraction of
    :data:`BINS` (40) equal-area bins, each 4 pi / 40 sr, holding at least one of them.

    Zero-length rows are ignored. Turning a board about one axis only traces a
    circle of directions, which hits at most about a third of the bins (the
    tests measure it); uniformly random orientations hit them all.
    """
    d = _readings(directions, 0)
    d = d[np.linalg.norm(d, axis=1) > 0.0]
    if not len(d):
        return 0.0
    return len(np.unique(bin_index(d))) / BINS


def _residual_rms(m: Array, offset: Array, w: Array, field_ut: float) -> float:
    """RMS of |W (m - b)| - B, uT: how far the readings sit from the fitted ellipsoid along its radius."""
    return float(np.sqrt(np.mean((np.linalg.norm((m - offset) @ w.T, axis=1) - field_ut) ** 2)))


def _result(m: Array, offset: Array, w: Array, field_ut: float, model: str) -> MagFit:
    """The fit as a :class:`MagFit`, with its residual and coverage over ``m``."""
    calibrated = (m - offset) @ w.T
    return MagFit(offset=(float(offset[0]), float(offset[1]), float(offset[2])),
                  soft_iron=(_row(w, 0), _row(w, 1), _row(w, 2)), field_ut=field_ut,
                  residual_ut=_residual_rms(m, offset, w, field_ut), coverage=coverage(calibrated),
                  readings=len(m), model=model)


def _row(w: Array, i: int) -> Vec3:
    return (float(w[i, 0]), float(w[i, 1]), float(w[i, 2]))


def _refuse_thin(share: float, min_coverage: float) -> None:
    """A clear refusal when the directions cover less than ``min_coverage``."""
    if share < min_coverage:
        raise MagFitError(f"too little coverage: the readings visit {share:.0%} of the directions, "
                          f"a fit needs {min_coverage:.0%}; turn the board through more orientations")


def _sphere(m: Array) -> tuple[Array, float]:
    """Centre and radius of the least-squares sphere (AN4246 sec. 6).

    |m - b|^2 = B^2 is 2 m . b + (B^2 - |b|^2) = |m|^2, linear in b and
    c = B^2 - |b|^2. Solved about the readings' mean (for conditioning); a
    design of rank below four (readings in a plane: a board turned about one
    axis) determines no sphere.
    """
    mean = m.mean(axis=0)
    x = m - mean
    scale = float(np.sqrt(np.mean(np.sum(x * x, axis=1))))
    if not scale > 0.0:
        raise MagFitError("the magnetometer readings are all the same: the board did not turn")
    x = x / scale
    design = np.column_stack([2.0 * x, np.ones(len(x))])
    singular = np.linalg.svd(design, compute_uv=False)
    if singular[-1] < 1e-6 * singular[0]:
        raise MagFitError("too little coverage: the readings lie in a plane (the board turned about "
                          "one axis only); turn it through more orientations")
    sol = np.linalg.lstsq(design, np.sum(x * x, axis=1), rcond=None)[0]
    centre = sol[:3]
    radius_sq = float(sol[3] + centre @ centre)
    if not radius_sq > 0.0:
        raise MagFitError("the magnetometer readings do not lie on a sphere")
    return mean + scale * centre, scale * math.sqrt(radius_sq)


def fit_sphere(m: ArrayLike, min_coverage: float = MIN_COVERAGE) -> MagFit:
    """Hard iron only: the centre b and radius B of the sphere |m - b| = B (AN4246 sec. 6), W = I.

    ``m`` (N, 3) readings in uT. Raises :class:`MagFitError` when they are
    too few, lie in a plane, or visit less than ``min_coverage`` of the
    directions about the fitted centre (:func:`coverage`).
    """
    x = _readings(m, SPHERE_MIN_READINGS)
    centre, radius = _sphere(x)
    fit = _result(x, centre, np.eye(3), radius, SPHERE)
    _refuse_thin(fit.coverage, min_coverage)
    return fit


# Li & Griffiths (2004) sec. 3: the constraint k J - I^2 = 1 on the quadric's quadratic
# coefficients (a, b, c, f, g, h), I = a + b + c, J = ab + bc + ca - f^2 - g^2 - h^2, written
# v1^T C1 v1 = 1; k = 4 makes every solution an ellipsoid.
_K = 4.0
_C1 = np.array([
    [-1.0, _K / 2 - 1, _K / 2 - 1, 0.0, 0.0, 0.0],
    [_K / 2 - 1, -1.0, _K / 2 - 1, 0.0, 0.0, 0.0],
    [_K / 2 - 1, _K / 2 - 1, -1.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, -_K, 0.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, -_K, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0, -_K],
])


def _li_griffiths(x: Array) -> tuple[Array, Array]:
    """The ellipsoid (x - c)^T A (x - c) = 1 fitted to points ``x`` (N, 3) near the unit sphere.

    Li & Griffiths (2004) sec. 3: the quadric a x^2 + b y^2 + c z^2 + 2 f yz
    + 2 g xz + 2 h xy + 2 p x + 2 q y + 2 r z + d = 0 with coefficients
    v = (v1, v2), v1 = (a, b, c, f, g, h), v2 = (p, q, r, d), minimising
    |D v|^2 (D the design, eq. 11; S = D^T D in blocks S11, S12, S22) subject
    to v1^T C1 v1 = 1. Eliminating v2 = -S22^-1 S12^T v1 leaves the
    eigenproblem C1^-1 (S11 - S12 S22^-1 S12^T) v1 = lambda v1 (eq. 15), whose
    one positive eigenvalue's eigenvector is the fit.
    """
    px, py, pz = x[:, 0], x[:, 1], x[:, 2]
    design = np.column_stack([px * px, py * py, pz * pz, 2 * py * pz, 2 * px * pz, 2 * px * py,
                              2 * px, 2 * py, 2 * pz, np.ones(len(x))])
    s = design.T @ design
    s11, s12, s22 = s[:6, :6], s[:6, 6:], s[6:, 6:]
    try:
        reduced = s11 - s12 @ np.linalg.solve(s22, s12.T)
        values, vectors = np.linalg.eig(np.linalg.solve(_C1, reduced))
        v1 = np.real(vectors[:, int(np.argmax(np.real(values)))])
        v2 = -np.linalg.solve(s22, s12.T @ v1)
        a, b, c, f, g, h = v1
        quad = np.array([[a, h, g], [h, b, f], [g, f, c]])
        centre = -np.linalg.solve(quad, v2[:3])
    except np.linalg.LinAlgError:
        raise MagFitError("the magnetometer readings determine no ellipsoid") from None
    level = float(centre @ quad @ centre - v2[3])  # (x - c)^T quad (x - c) = level
    shape = quad / level
    if not np.all(np.linalg.eigvalsh(shape) > 0.0):
        raise MagFitError("the magnetometer readings do not lie on an ellipsoid")
    return shape, centre


def _sqrt_spd(a: Array) -> Array:
    """The symmetric positive definite square root of a symmetric positive definite matrix."""
    values, vectors = np.linalg.eigh(a)
    root = (vectors * np.sqrt(values)) @ vectors.T
    return np.asarray(0.5 * (root + root.T))  # exactly symmetric (the product rounds each half apart)


def _ellipsoid(m: Array, centre: Array, radius: float) -> tuple[Array, Array, float]:
    """Hard iron b, W (symmetric, det 1) and B from the readings ``m``, about a sphere fit.

    The readings are first normalised by the sphere (x = (m - b0) / B0) for
    conditioning. Li & Griffiths's k = 4 holds every ellipsoid whose shortest
    semi-axis is at least half its longest (their sec. 3), which 20 % of soft
    iron may just exceed; so the fit is repeated once on the points whitened
    by the first fit, which lie near a sphere, and the two composed: with
    T = A1^(1/2), y = T (x - c1), the second fit (y - c2)^T A2 (y - c2) = 1
    is (x - c)^T T A2 T (x - c) = 1 with c = c1 + T^-1 c2. Then, in uT,
    A_m = A / B0^2 and (1) gives W = B A_m^(1/2) with det W = 1, so
    B = det(A_m)^(-1/6).
    """
    x = (m - centre) / radius
    a1, c1 = _li_griffiths(x)
    t = _sqrt_spd(a1)
    a2, c2 = _li_griffiths((x - c1) @ t.T)
    shape = t @ a2 @ t
    offset = centre + radius * (c1 + np.linalg.solve(t, c2))
    shape_ut = shape / radius**2
    field_ut = float(np.linalg.det(shape_ut)) ** (-1.0 / 6.0)
    return offset, field_ut * _sqrt_spd(0.5 * (shape_ut + shape_ut.T)), field_ut


def fit_ellipsoid(m: ArrayLike, min_coverage: float = MIN_COVERAGE,
                  ellipsoid_coverage: float = ELLIPSOID_COVERAGE) -> MagFit:
    """Hard iron and symmetric soft iron: the ellipsoid (1) fitted by Li & Griffiths (2004).

    ``m`` (N, 3) readings in uT. A sphere (:func:`fit_sphere`) is fitted
    first; readings covering less than ``min_coverage`` of the directions
    about it are refused (:class:`MagFitError`). Readings covering less than
    ``ellipsoid_coverage``, fewer than :data:`ELLIPSOID_MIN_READINGS` of
    them, or not shaped as an ellipsoid, are too thin to pin the soft iron's
    six more parameters: the sphere is returned (``model`` :data:`SPHERE`).
    """
    x = _readings(m, SPHERE_MIN_READINGS)
    sphere = fit_sphere(x, min_coverage)
    if sphere.coverage < ellipsoid_coverage or len(x) < ELLIPSOID_MIN_READINGS:
        return sphere
    try:
        offset, w, field_ut = _ellipsoid(x, np.array(sphere.offset), sphere.field_ut)
    except MagFitError:
        return sphere
    return _result(x, offset, w, field_ut, ELLIPSOID)


def judge(fit: MagFit, max_residual: float = MAX_RESIDUAL) -> str:
    """Why ``fit`` is not a calibration to use ("" when it is): a residual beyond ``max_residual``
    of the field (the field changes as the board moves: a room's disturbance that varies with
    position, or a magnet near the board), or a strength no place on earth has."""
    if fit.relative_residual > max_residual:
        return (f"the field changes as the board moves: residual {fit.residual_ut:.1f} uT, "
                f"{fit.relative_residual:.0%} of its {fit.field_ut:.0f} uT (a magnet or steel near?)")
    if not FIELD_MIN_UT <= fit.field_ut <= FIELD_MAX_UT:
        return (f"a field of {fit.field_ut:.0f} uT is not the earth's "
                f"({FIELD_MIN_UT:.0f}-{FIELD_MAX_UT:.0f} uT with the board's soft iron)")
    return ""


COLLECTING = "collecting"
FITTED = "fitted"
INCONSISTENT = "inconsistent"


@dataclass(frozen=True)
class OnlineParams:
    """Settings of :class:`OnlineMagFit` (counts are samples; "at 100 Hz" gives the time).

    The readings are kept one per cube of ``cell_ut`` on a side: the earth's
    field of 45 uT (:data:`tracker.motion.EARTH_FIELD_UT`) draws a sphere of
    about 25 000 uT^2, crossed by some 1 500 cubes of 5 uT, so ``capacity``
    holds it even at 67 uT with soft iron, and each cube is wider than the
    AK8963's noise (0.6 uT RMS, :data:`tracker.sim.MAG_NOISE_RMS_UT`), so a pose
    held still fills only the few cubes its noise reaches.
    """

    cell_ut: float = 5.0  # the side of the cubes that each keep one reading
    capacity: int = 4096  # readings kept at most (the oldest cube gives way)
    forget_after: int = 180_000  # a cube not visited for this many samples (30 min at 100 Hz) is dropped
    refit_every: int = 300  # samples between fits at least (3 s at 100 Hz)
    min_coverage: float = ELLIPSOID_COVERAGE  # OnlineMagFit fits nothing below this coverage
    ellipsoid_coverage: float = ELLIPSOID_COVERAGE
    max_residual: float = MAX_RESIDUAL  # residual as a share of B beyond which a fit is inconsistent


class OnlineMagFit:
    """Readings collected in play, kept bounded, fitted now and then (:func:`fit_ellipsoid`).

    :meth:`add` takes one reading in plain floats: it keeps the latest reading
    in each cube of ``cell_ut`` of the reading space (a dictionary from the
    cube to a slot of fixed arrays). So memory stays below ``capacity``
    however long the session, a pose held for minutes refreshes the same few
    cubes instead of outweighing the rest, and the kept readings spread
    evenly over the ellipsoid's surface. Raw readings are kept, not means
    (a mean over a patch of the curved surface lies inside it), and no centre
    is needed to file them, so nothing is refiled when the fit changes. A
    new cube takes the slot of the oldest cube once ``capacity`` is reached;
    cubes not visited for ``forget_after`` samples are dropped at the next
    fit (the board's hard iron changes when it is magnetised).

    :meth:`fit` fits the kept readings: :attr:`status` is :data:`COLLECTING`
    while they cover less than ``min_coverage`` of the directions,
    :data:`INCONSISTENT` when the fit fails :func:`judge`, else
    :data:`FITTED`; :attr:`result` is the latest fit that was
    :data:`FITTED` (kept through later failures), :attr:`latest` the latest
    fit at all, :attr:`message` a line for a HUD.
    """

    def __init__(self, params: OnlineParams = OnlineParams()) -> None:
        if not (params.cell_ut > 0.0 and params.capacity >= ELLIPSOID_MIN_READINGS
                and params.refit_every >= 1 and params.forget_after >= 1):
            raise ValueError(f"OnlineParams need a cell above 0 uT, a capacity of at least "
                             f"{ELLIPSOID_MIN_READINGS} and counts of at least 1: {params}")
        self.params = params
        n = params.capacity
        self._slot: dict[tuple[int, int, int], int] = {}
        self._keys: list[tuple[int, int, int] | None] = [None] * n
        self._x: list[float] = [0.0] * n
        self._y: list[float] = [0.0] * n
        self._z: list[float] = [0.0] * n
        self._seen: list[int] = [0] * n  # the sample count when the slot's cube was last visited
        self._next = 0  # the slot a new cube takes
        self._samples = 0
        self._fitted_at = 0
        self.status = COLLECTING
        self.message = "turn the board through many orientations to calibrate the magnetometer"
        self.result: MagFit | None = None
        self.latest: MagFit | None = None

    @property
    def kept(self) -> int:
        """Readings kept now."""
        return len(self._slot)

    @property
    def due(self) -> bool:
        """Whether ``refit_every`` samples have come since the last fit."""
        return self._samples - self._fitted_at >= self.params.refit_every

    def add(self, m: Vec3) -> bool:
        """Keep one reading (uT); a non-finite one is ignored. Returns :attr:`due`."""
        x, y, z = m
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            return self.due
        self._samples += 1
        cell = self.params.cell_ut
        key = (math.floor(x / cell), math.floor(y / cell), math.floor(z / cell))
        slot = self._slot.get(key)
        if slot is None:
            slot = self._next
            self._next = (slot + 1) % self.params.capacity
            old = self._keys[slot]
            if old is not None:
                del self._slot[old]
            self._keys[slot] = key
            self._slot[key] = slot
        self._x[slot] = x
        self._y[slot] = y
        self._z[slot] = z
        self._seen[slot] = self._samples
        return self.due

    def readings(self) -> Array:
        """The readings kept, (kept, 3) uT."""
        slots = sorted(self._slot.values())
        return np.array([[self._x[i], self._y[i], self._z[i]] for i in slots], dtype=np.float64).reshape(-1, 3)

    def _forget_stale(self) -> None:
        """Drop the cubes not visited for ``forget_after`` samples."""
        oldest = self._samples - self.params.forget_after
        for key, slot in list(self._slot.items()):
            if self._seen[slot] < oldest:
                del self._slot[key]
                self._keys[slot] = None

    def fit(self) -> MagFit | None:
        """Fit the readings kept; :attr:`result` after it (None until a fit was :data:`FITTED`)."""
        p = self.params
        self._fitted_at = self._samples
        self._forget_stale()
        try:
            fit = fit_ellipsoid(self.readings(), p.min_coverage, p.ellipsoid_coverage)
        except MagFitError as e:
            self.status, self.message = COLLECTING, str(e)
            return self.result
        self.latest = fit
        reason = judge(fit, p.max_residual)
        if reason:
            self.status, self.message = INCONSISTENT, reason
        else:
            self.status, self.result = FITTED, fit
            self.message = (f"magnetometer calibrated: {fit.field_ut:.0f} uT, residual "
                            f"{fit.residual_ut:.1f} uT, {fit.coverage:.0%} of the directions")
        return self.result
