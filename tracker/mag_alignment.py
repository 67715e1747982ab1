"""The magnetometer's frame turned onto the accelerometer's, from the dip being the same everywhere.

Why. The fusion compares the field with gravity in one frame, the
accelerometer's calibrated one. The magnetometer's calibration
(:mod:`tracker.magfit`) finds its hard and soft iron, which fix its frame only
up to a rotation, and the frames of the two sensors differ anyway: the
accelerometer's cross-axis sensitivity (+-2 %, PS-MPU-9250A-01 table 2) turns
its calibrated frame by up to a degree or so (:mod:`tracker.accel_procedure`),
and the AK8963 is a die of its own in the package. A field a degree off
gravity's frame is a heading a degree off, changing with the orientation,
which no wearing calibration takes out.

How. The earth's field and gravity are fixed in the room, so in the board's
frame the angle between them is the same whatever the orientation: with h_k
the calibrated field's direction and u_k gravity's (the accelerometer's
specific force over its length) at sample k, u_k . (R h_k) = s for every k,
s = -sin(dip) and R the rotation from the magnetometer's frame to the
accelerometer's (the dot-product invariance of X. Li and Z. Li, "A new
calibration method for tri-axial field sensors in strap-down navigation
systems", Meas. Sci. Technol. 23 (2012) 105105, sec. 3). About the current
R, a small turn phi (R' = exp([phi]x) R) changes the dot product by
phi . (R h_k x u_k), so each sample is a linear equation in phi and s,
solved by least squares and iterated. R h_k x u_k is the room's east (times
cos dip) seen from the board, so the turns the board makes decide which
directions of phi the samples see: a spiral about the field's direction
(the tumble :mod:`tracker.maker_sim` makes, and one a maker watching the
sphere fill in may well make) sweeps it through a plane and leaves the
third direction barely seen. A prior holds what the samples do not (each
component of phi a Gaussian of ``prior_deg``, each dot product's misfit one
of ``dot_noise``: the least squares of a maximum a posteriori fit, Bishop,
"Pattern Recognition and Machine Learning", 2006, sec. 3.3). An alignment
from a board turned through too few orientations (two directions barely
seen), or that asks for more than ``max_turn_deg``, is refused and the
identity kept.

How well a direction is seen. With the dip s unknown too, the samples'
information about phi along a unit direction v is N v^T C v / dot_noise^2,
C the covariance of the R h_k x u_k over the N samples (s takes their mean;
the Schur complement of the normal equations), and the prior's is
1 / prior^2. So the second best seen direction carries
N lambda_2 (prior / dot_noise)^2 times the prior's information, lambda_2 C's
middle eigenvalue; at ``min_information`` (3) its posterior spread is half
the prior's, 1 / sqrt(1 + 3). Below that the fit is refused: the poses say
little about two of the three directions. (Ten poses whose middle
eigenvalue is 0.019 carry 33 priors' worth, a posterior spread of 0.26 deg,
and are aligned; a fixed bound on lambda_2 of 0.02 refused them.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


@dataclass(frozen=True)
class AlignmentParams:
    """Settings of :func:`fit_alignment`.

    ``max_turn_deg``: the most the two frames may differ (the accelerometer's
    cross-axis terms turn its frame by about a degree; 5 deg is a board or a
    fit gone wrong); ``min_information``: the least information the second
    best seen direction of phi must carry from the samples, in units of the
    prior's (module docstring; a board turned through all orientations gives
    lambda_2 = cos^2(dip) / 3, 0.1 or more below a dip of 57 deg: ten such
    poses carry some 170 priors' worth);
    ``prior_deg``: the prior's spread of each component of phi (the
    accelerometer's frame turns by the antisymmetric part of its cross-axis
    terms, within +-2 %, about 1.1 deg); ``dot_noise``: one pose's misfit (its
    gravity known to about 0.1 deg after the accelerometer's calibration, its
    field averaged over the pose: 0.002); ``iterations``: of the linearised solve.
    """

    max_turn_deg: float = 5.0
    min_information: float = 3.0
    prior_deg: float = 1.5
    dot_noise: float = 0.002
    iterations: int = 4


@dataclass(frozen=True)
class Alignment:
    """``rotation`` R (the magnetometer's calibrated frame onto the accelerometer's; the identity when
    refused), the dip (degrees, from the fitted s), the RMS misfit of the dot products (as an angle,
    degrees), and why it was refused ("" when it was not)."""

    rotation: Array = field(default_factory=lambda: np.eye(3))
    dip_deg: float = math.nan
    residual_deg: float = math.nan
    problem: str = ""

    @property
    def ok(self) -> bool:
        return not self.problem

    @property
    def turn_deg(self) -> float:
        """How far R turns, degrees."""
        return math.degrees(math.acos(max(-1.0, min(1.0, (float(np.trace(self.rotation)) - 1.0) / 2.0))))

    def describe(self) -> str:
        """One line for the maker: the turn, or why there is none."""
        if self.ok:
            return f"turned {self.turn_deg:.2f} deg onto the accelerometer's frame"
        return f"not turned onto the accelerometer's frame ({self.problem})"


def _turn(phi: Array) -> Array:
    """exp([phi]x) by Rodrigues' formula."""
    angle = float(np.linalg.norm(phi))
    if angle == 0.0:
        return np.eye(3)
    k = phi / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * kx @ kx


def fit_alignment(field_ut: Array, specific_force: Array, params: AlignmentParams = AlignmentParams()) -> Alignment:
    """R and the dip from calibrated fields (N, 3) and specific forces (N, 3) read together (module docstring)."""
    h = field_ut / np.linalg.norm(field_ut, axis=1, keepdims=True)
    u = specific_force / np.linalg.norm(specific_force, axis=1, keepdims=True)
    east = np.cross(h, u)
    middle = float(np.linalg.eigvalsh(np.cov(east, rowvar=False, bias=True))[1]) if len(u) > 3 else 0.0
    information = len(u) * middle * (math.radians(params.prior_deg) / params.dot_noise) ** 2
    if information < params.min_information:
        return Alignment(problem=f"the board was not turned through enough orientations to align the "
                                 f"magnetometer with the accelerometer (the poses see a second direction "
                                 f"{information:.1f} times as well as the prior, {params.min_information:g} needed)")
    weight = params.dot_noise / math.radians(params.prior_deg)  # the prior's rows (module docstring)
    prior = np.hstack([weight * np.eye(3), np.zeros((3, 1))])
    rotation, s, phi = np.eye(3), 0.0, np.zeros(3)
    for _ in range(params.iterations):
        turned = h @ rotation.T
        rows = np.vstack([np.column_stack([np.cross(turned, u), -np.ones(len(u))]), prior])
        target = np.concatenate([-np.sum(u * turned, axis=1), -weight * phi])
        solution = np.linalg.lstsq(rows, target, rcond=None)[0]
        rotation, s, phi = _turn(solution[:3]) @ rotation, float(solution[3]), phi + solution[:3]
    misfit = np.sum(u * (h @ rotation.T), axis=1) - s
    found = Alignment(rotation, math.degrees(math.asin(max(-1.0, min(1.0, -s)))),
                      math.degrees(float(np.sqrt(np.mean(misfit ** 2)))))
    if found.turn_deg > params.max_turn_deg:
        return Alignment(problem=f"the magnetometer would turn {found.turn_deg:.1f} deg onto the accelerometer "
                                 f"(at most {params.max_turn_deg:g}): not aligned")
    return found
