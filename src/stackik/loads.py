"""Statics of a stack (DESIGN §10): leg forces under gravity and a payload, and how close
each platform is to a singularity.

Conventions (``docs/loads.md``):

* Lengths in mm, masses in kg, forces in N, gravity in m/s^2; moments are **N m at the API**
  (:class:`Load`) and N mm inside this module (positions stay in mm: a moment arm [mm]
  times a force [N] is N mm; an API moment is multiplied by 1000 on entry).
* Leg force ``f > 0`` is **compression**: the leg pushes its two plates apart, i.e. it
  pushes its top plate along the unit leg direction ``u_k`` (from the bottom joint to the
  top joint) and its bottom plate along ``-u_k``.
* Masses: platform i's ``plate_mass`` at the centre of plate i (its top plate);
  ``leg_mass`` of each leg split half at each of its two joints; the payload ``Load.mass``
  at the end-effector origin plus ``Load.com`` (end-effector frame).
* The cut: platform i carries the body above its legs, i.e. plates i..n with everything
  fixed to them (the payload and external wrench, the legs of platforms i+1..n, the top
  halves of platform i's own legs). With ``w_i`` that body's weight and external wrench
  (moment about the origin ``O_i`` of plate i), expressed in plate i-1's frame, the six
  leg forces solve ``G_i f_i + w_i = 0`` with the unit leg wrenches as columns:
  ``G_i[:, k] = (u_k, (R_i t_k) x u_k)``.
* Singularity measure: the singular values of ``D_i G_i`` with
  ``D_i = diag(1, 1, 1, 1/L_i, 1/L_i, 1/L_i)``, ``L_i`` = the mean distance of platform
  i's top nodes from its top plate's centre (:func:`characteristic_length`; 150 mm for
  the reference geometry), which makes the moment rows dimensionless. Each column of
  ``D_i G_i`` has a norm between 1 and sqrt(2). A platform whose condition number exceeds
  :data:`SINGULAR_CONDITION` (or whose matrix is not finite) is **singular**: its six
  forces are ``inf``, never an exception.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik._arrays import finite_array, readonly
from stackik.geometry import Stack, finite_number
from stackik.kinematics import lift_planar
from stackik.platform import _check_phi, _cross, validate_pose_array
from stackik.rotations import euler_zyx

__all__ = [
    "GRAVITY",
    "LOAD_FRAMES",
    "SINGULAR_CONDITION",
    "Conditioning",
    "Load",
    "Statics",
    "characteristic_length",
    "leg_forces",
    "statics",
    "wrench_conditioning",
]

FloatArray = NDArray[np.float64]

#: Gravity presets [m/s^2] in the base frame, along -z (base upright on the ground):
#: standard gravity (CGPM 1901) and the mean surface gravity of the Moon and Mars (NASA
#: planetary fact sheets).
GRAVITY: Mapping[str, tuple[float, float, float]] = MappingProxyType(
    {
        "earth": (0.0, 0.0, -9.80665),
        "moon": (0.0, 0.0, -1.62),
        "mars": (0.0, 0.0, -3.71),
        "none": (0.0, 0.0, 0.0),
    }
)

#: Frames an external wrench may be given in.
LOAD_FRAMES = ("base", "end_effector")

#: A platform whose dimensionless leg wrench matrix has a larger condition number is
#: singular (its forces would keep fewer than 4 significant digits): forces ``inf``.
SINGULAR_CONDITION = 1e12

_MM_PER_M = 1000.0  # N m -> N mm


def _vector3(value: Any, name: str) -> FloatArray:
    """A finite (3,) float array (read-only), or a ValueError naming ``name``."""
    return readonly(finite_array(value, name, (3,)))


@dataclass(frozen=True, eq=False)
class Load:
    """What the stack carries besides its own weight: a payload and an external wrench.

    Parameters
    ----------
    force : array_like, shape (3,)
        External force on the end effector [N], in ``frame``.
    moment : array_like, shape (3,)
        External moment on the end effector about its origin [N m], in ``frame``.
    frame : {"base", "end_effector"}
        Frame of ``force`` and ``moment``: the base frame, or the end effector's own (the
        wrench turns with it).
    mass : float
        Payload mass [kg], finite and ``>= 0``, at the end-effector origin plus ``com``.
    com : array_like, shape (3,)
        Payload centre of mass relative to the end-effector origin [mm], end-effector frame.
    gravity : array_like, shape (3,), or {"earth", "moon", "mars", "none"}
        Gravitational acceleration in the base frame [m/s^2] (any direction: the base may
        hang from a truss or sit on a wall), or a preset of :data:`GRAVITY` (along -z). It
        acts on the payload and on every plate and leg mass of the geometry. Stored as the
        (3,) vector.

    Raises
    ------
    ValueError
        Naming the bad field (negative or non-finite mass, unknown gravity name, ...).
    """

    force: FloatArray = (0.0, 0.0, 0.0)  # type: ignore[assignment]
    moment: FloatArray = (0.0, 0.0, 0.0)  # type: ignore[assignment]
    frame: str = "base"
    mass: float = 0.0
    com: FloatArray = (0.0, 0.0, 0.0)  # type: ignore[assignment]
    gravity: FloatArray | str = "earth"

    def __post_init__(self) -> None:
        object.__setattr__(self, "force", _vector3(self.force, "force"))
        object.__setattr__(self, "moment", _vector3(self.moment, "moment"))
        if not isinstance(self.frame, str) or self.frame not in LOAD_FRAMES:
            raise ValueError(f"frame: expected one of {list(LOAD_FRAMES)}, got {self.frame!r}")
        mass = finite_number(self.mass, "mass")
        if mass < 0:
            raise ValueError(f"mass: must be >= 0 kg, got {mass}")
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "com", _vector3(self.com, "com"))
        g: Any = self.gravity
        if isinstance(g, str):
            if g not in GRAVITY:
                raise ValueError(f"gravity: unknown preset {g!r}; use one of {list(GRAVITY)}")
            g = GRAVITY[g]
        object.__setattr__(self, "gravity", _vector3(g, "gravity"))

    @property
    def g(self) -> FloatArray:
        """The gravity vector [m/s^2] in the base frame, shape (3,)."""
        return np.asarray(self.gravity, dtype=float)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle through the constructor (the arrays come back validated and read-only)."""
        args = (self.force, self.moment, self.frame, self.mass, self.com, self.gravity)
        return (Load, args)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Load):
            return NotImplemented
        return (
            self.frame == other.frame
            and self.mass == other.mass
            and all(
                np.array_equal(getattr(self, k), getattr(other, k))
                for k in ("force", "moment", "com", "gravity")
            )
        )

    def __hash__(self) -> int:
        arrays = (self.force, self.moment, self.com, self.gravity)
        return hash((self.frame, self.mass, *(np.asarray(a).tobytes() for a in arrays)))


# =========================================================================================
# Core: leg wrench matrices and cut-body wrenches of a batch of poses
# =========================================================================================
def characteristic_length(stack: Stack) -> FloatArray:
    """The length ``L_i`` [mm] that makes platform i's leg wrench matrix dimensionless.

    ``L_i`` is the mean distance of platform i's top nodes from its top plate's centre:
    the moment arm of a unit leg force about that centre is at most ``|t_k|``. 150 mm for
    the reference geometry. Shape (n,).
    """
    return stack.derived(  # type: ignore[no-any-return]
        "statics_length", lambda s: _readonly(np.linalg.norm(s.top_nodes, axis=2).mean(axis=1))
    )


def _readonly(a: FloatArray) -> FloatArray:
    a.setflags(write=False)
    return a


def _pose_parts(
    stack: Stack, q: ArrayLike, phi: float | None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(q, P, R)``: the validated pose (..., n, k) and per-platform translations
    (..., n, 3) [mm] and rotations (..., n, 3, 3) of a spatial (k = 6) or planar (k = 3,
    needs ``phi``) pose."""
    try:
        raw = np.asarray(q, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"q: expected an array of numbers ({exc})") from None
    ncols = raw.shape[-1] if raw.ndim >= 2 else 0
    if ncols == 3:
        if phi is None:
            raise ValueError("phi: a planar pose (n, 3) needs the plane angle phi [rad]")
        qa = validate_pose_array(raw, stack.n, 3)
        P, R = lift_planar(qa, _check_phi(phi))
        return qa, P, R
    if ncols == 6 and phi is None:
        qa = validate_pose_array(raw, stack.n, 6)
        return qa, qa[..., :3], euler_zyx(qa[..., 3:])
    if ncols == 6:
        raise ValueError("phi: only a planar pose (n, 3) takes phi; this pose is (n, 6)")
    raise ValueError(
        f"q: expected shape (..., {stack.n}, 6) (spatial) or (..., {stack.n}, 3) with phi "
        f"(planar), got {raw.shape}"
    )


def lumped_masses(stack: Stack, load: Load) -> tuple[FloatArray, FloatArray]:
    """The masses the statics lump on each top plate j = 1..n: ``m`` (n,) [kg] (the plate,
    half of its own legs, half of the legs above it, the payload on the last) and their
    first moment ``c`` (n, 3) [kg mm] in that plate's frame (the half legs at their
    joints, the payload at its centre of mass)."""
    half = 0.5 * np.asarray(stack.leg_mass, dtype=float)  # (n,) per joint
    m = np.asarray(stack.plate_mass, dtype=float) + 6.0 * half
    m[:-1] += 6.0 * half[1:]
    m[-1] += load.mass
    c = half[:, None] * stack.top_nodes.sum(axis=1)
    c[:-1] += half[1:, None] * stack.base_nodes[1:].sum(axis=1)
    c[-1] += load.mass * np.asarray(load.com, dtype=float)
    return m, c


def _system(
    stack: Stack, P: FloatArray, R: FloatArray, load: Load
) -> tuple[FloatArray, FloatArray]:
    """Dimensionless leg wrench matrices ``D G`` (..., n, 6, 6) and cut wrenches ``D w``
    (..., n, 6) [N] (moments about the top plate centre, divided by ``L_i`` [mm]), both in
    the frame of each platform's bottom plate."""
    n = stack.n
    batch = P.shape[:-2]
    # chain: A[i] = orientation of plate i, O[i] = its origin (base frame) [mm]
    dtype = np.result_type(P, R)  # complex too: stackik.formulation.forces differentiates
    A = np.empty(batch + (n + 1, 3, 3), dtype=dtype)  # by the complex step through here
    O = np.empty(batch + (n + 1, 3), dtype=dtype)
    A[..., 0, :, :] = np.eye(3)
    O[..., 0, :] = 0.0
    for i in range(n):
        step = np.einsum("...ij,...j->...i", A[..., i, :, :], P[..., i, :])
        O[..., i + 1, :] = O[..., i, :] + step
        A[..., i + 1, :, :] = A[..., i, :, :] @ R[..., i, :, :]

    # legs in each bottom plate's frame; unit directions; moment arms about the top centre
    Rt = np.einsum("...ij,...kj->...ki", R, stack.top_nodes)  # (..., n, 6, 3)
    l = Rt + P[..., None, :] - stack.base_nodes
    u = l / np.sqrt(np.sum(l * l, axis=-1, keepdims=True))  # (no abs: complex-step safe)
    L = characteristic_length(stack)
    G = np.concatenate([u, _cross(Rt, u) / L[:, None, None]], axis=-1)  # (..., n, 6 legs, 6)
    G = np.swapaxes(G, -1, -2)  # columns = legs

    m, c = lumped_masses(stack, load)
    s = m[:, None] * O[..., 1:, :] + np.einsum("...jab,jb->...ja", A[..., 1:, :, :], c)
    # the body above platform i's legs: plates i..n (suffix sums)
    M_cut = np.cumsum(m[::-1])[::-1]  # (n,)
    S_cut = np.flip(np.cumsum(np.flip(s, axis=-2), axis=-2), axis=-2)  # (..., n, 3)

    g = load.g
    F_ext, M_ext = load.force, load.moment * _MM_PER_M
    if load.frame == "end_effector":
        F_ext = np.einsum("...ij,j->...i", A[..., n, :, :], F_ext)
        M_ext = np.einsum("...ij,j->...i", A[..., n, :, :], M_ext)
    F_ext = np.broadcast_to(F_ext, batch + (3,))
    M_ext = np.broadcast_to(M_ext, batch + (3,))
    O_top = O[..., 1:, :]  # origin of each platform's top plate
    F = F_ext[..., None, :] + M_cut[:, None] * g  # (..., n, 3) [N]
    M = (
        M_ext[..., None, :]
        + _cross(O[..., n, None, :] - O_top, np.broadcast_to(F_ext[..., None, :], O_top.shape))
        + _cross(S_cut - M_cut[:, None] * O_top, np.broadcast_to(g, O_top.shape))
    )  # [N mm] about O_i
    w = np.concatenate([F, M / L[:, None]], axis=-1)
    # into the bottom plate's frame: A_{i-1}^T
    Ab = A[..., :n, :, :]
    w_loc = np.concatenate(
        [
            np.einsum("...ji,...j->...i", Ab, w[..., :3]),
            np.einsum("...ji,...j->...i", Ab, w[..., 3:]),
        ],
        axis=-1,
    )
    return G, w_loc


def _svd(G: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(U, s, Vt, singular)`` of the (..., 6, 6) matrices; a non-finite matrix (or one the
    SVD does not converge on) is replaced by the identity and flagged singular."""
    bad = ~np.all(np.isfinite(G), axis=(-1, -2))
    Gs = np.where(bad[..., None, None], np.eye(6), G)
    try:
        U, s, Vt = np.linalg.svd(Gs)
    except np.linalg.LinAlgError:  # pragma: no cover - LAPACK failure on finite input
        flat = Gs.reshape(-1, 6, 6)
        U = np.empty_like(flat)
        Vt = np.empty_like(flat)
        sv = np.empty(flat.shape[:-1])
        bflat = bad.reshape(-1).copy()
        for k in range(flat.shape[0]):
            try:
                U[k], sv[k], Vt[k] = np.linalg.svd(flat[k])
            except np.linalg.LinAlgError:
                U[k], sv[k], Vt[k] = np.eye(6), np.ones(6), np.eye(6)
                bflat[k] = True
        U, s, Vt = (a.reshape(Gs.shape[:-2] + a.shape[1:]) for a in (U, sv, Vt))
        bad = bflat.reshape(bad.shape)
    with np.errstate(divide="ignore"):
        cond = s[..., 0] / s[..., -1]
    singular = bad | ~(cond <= SINGULAR_CONDITION)
    return U, s, Vt, singular


def _solve(
    stack: Stack, P: FloatArray, R: FloatArray, load: Load
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(f, sigma_min, condition, singular)``: leg forces (..., n, 6) [N] (inf on singular
    platforms) and the dimensionless conditioning (..., n) of each platform."""
    G, w = _system(stack, P, R, load)
    U, s, Vt, singular = _svd(G)
    s_safe = np.where(singular[..., None], 1.0, s)
    # f = -G^-1 w = -V diag(1/s) U^T w
    f = -np.einsum("...ji,...j->...i", Vt, np.einsum("...ji,...j->...i", U, w) / s_safe)
    f = np.where(singular[..., None], np.inf, f)
    sigma_min = np.where(singular & ~np.all(np.isfinite(G), axis=(-1, -2)), 0.0, s[..., -1])
    with np.errstate(divide="ignore"):
        condition = np.where(sigma_min > 0, s[..., 0] / np.maximum(sigma_min, 1e-300), np.inf)
    return f, sigma_min, condition, singular


def _load(load: Load | None) -> Load:
    if load is None:
        return _NO_LOAD
    if not isinstance(load, Load):
        raise ValueError(f"load: expected a stackik.Load or None, got {type(load).__name__}")
    return load


_NO_LOAD = Load()


# =========================================================================================
# Public API
# =========================================================================================
def leg_forces(
    stack: Stack, q: ArrayLike, load: Load | None = None, *, phi: float | None = None
) -> FloatArray:
    """Axial force of every leg [N], **compression positive**, at a pose under a load.

    Platform i's six legs hold the body above them (the payload and external wrench,
    plates i..n, the legs of platforms i+1..n, the top halves of its own legs) against its
    weight and the external wrench: ``G_i(q) f_i + w_i(q) = 0`` (module doc). Positions are
    in mm inside, moments in N m at the API (:class:`Load`).

    Parameters
    ----------
    stack : Stack
        Geometries with ``plate_mass``, ``leg_mass`` [kg] (default 0: massless).
    q : array_like, shape (..., n, 6) or (..., n, 3)
        Spatial pose rows ``[x, y, z, yaw, pitch, roll]`` [mm, rad], or planar rows
        ``[rho, z, theta]`` [mm, mm, rad] with ``phi``; leading batch axes allowed.
    load : Load, optional
        Payload and external wrench; None = ``Load()``: no payload, earth gravity (the
        stack's own weight only).
    phi : float, optional
        Plane angle [rad] of a planar pose (required for it, refused for a spatial pose).

    Returns
    -------
    f : ndarray, shape (..., n, 6)
        ``f[..., i, k]`` = force of leg k of platform i [N]; ``inf`` for all six legs of a
        singular platform (see :func:`statics` for which).
    """
    _, P, R = _pose_parts(stack, q, phi)
    return _solve(stack, P, R, _load(load))[0]


class Conditioning(NamedTuple):
    """Distance of each platform from a singularity (see the module doc for the scaling).

    sigma_min : ndarray, shape (..., n)
        Smallest singular value of the dimensionless leg wrench matrix ``D_i G_i``
        (0 = singular; columns have norms in [1, sqrt 2]).
    condition : ndarray, shape (..., n)
        Its condition number ``sigma_max / sigma_min`` (inf when singular).
    """

    sigma_min: FloatArray
    condition: FloatArray


def wrench_conditioning(stack: Stack, q: ArrayLike, *, phi: float | None = None) -> Conditioning:
    """Per platform, the smallest singular value and condition number of its leg wrench
    matrix made dimensionless by :func:`characteristic_length` (independent of any load).

    Parameters
    ----------
    q : array_like, shape (..., n, 6) or (..., n, 3)
        As in :func:`leg_forces` (planar needs ``phi`` [rad]).

    Returns
    -------
    Conditioning
        ``(sigma_min, condition)``, each of shape (..., n).
    """
    _, P, R = _pose_parts(stack, q, phi)
    _, sigma_min, condition, _ = _solve(stack, P, R, _NO_LOAD)
    return Conditioning(sigma_min, condition)


@dataclass(frozen=True, eq=False)
class Statics:
    """Leg forces and singularity margins of one pose under one load (:func:`statics`).

    Attributes
    ----------
    leg_forces : ndarray, shape (n, 6)
        Axial leg forces [N], compression positive; ``inf`` on a singular platform.
    force_max : ndarray, shape (n,)
        Each platform's leg force limit [N] (``inf`` = none).
    force_margin : ndarray, shape (n, 6)
        ``force_max - |f|`` [N]: negative = over the limit; ``inf`` without a limit,
        ``-inf`` on a singular platform.
    force_ratio : ndarray, shape (n, 6)
        ``|f| / force_max`` (0 without a limit, ``inf`` on a singular platform).
    sigma_min, condition : ndarray, shape (n,)
        Conditioning of each platform's dimensionless leg wrench matrix (:class:`Conditioning`).
    length : ndarray, shape (n,)
        The characteristic length ``L_i`` [mm] used to scale the moment rows.
    singular : ndarray of bool, shape (n,)
        Platforms at a singularity (condition > :data:`SINGULAR_CONDITION`).
    """

    leg_forces: FloatArray
    force_max: FloatArray
    force_margin: FloatArray
    force_ratio: FloatArray
    sigma_min: FloatArray
    condition: FloatArray
    length: FloatArray
    singular: NDArray[np.bool_]

    @property
    def peak_force(self) -> float:
        """Largest ``|f|`` over all legs [N] (inf if any platform is singular)."""
        return float(np.abs(self.leg_forces).max())

    @property
    def peak_force_ratio(self) -> float:
        """Largest ``|f| / force_max`` over all legs (0 without limits, inf if singular)."""
        return float(self.force_ratio.max())

    @property
    def singular_platforms(self) -> tuple[int, ...]:
        """Numbers (1 = bottom) of the singular platforms."""
        return tuple(int(i) + 1 for i in np.flatnonzero(self.singular))

    @property
    def message(self) -> str:
        """One line for a user: the peak force and ratio, or which platform is singular."""
        if self.singular.any():
            which = ", ".join(str(i) for i in self.singular_platforms)
            return (
                f"platform(s) {which} of {self.singular.size} at a singularity (leg wrench "
                f"matrix not invertible): leg forces infinite"
            )
        i, k = np.unravel_index(int(np.argmax(np.abs(self.leg_forces))), self.leg_forces.shape)
        text = f"peak leg force {self.peak_force:.6g} N (platform {i + 1}, leg {k})"
        if np.isfinite(self.force_max).any():
            text += f", {self.peak_force_ratio:.4g} of its limit"
        return text


def statics(
    stack: Stack, q: ArrayLike, load: Load | None = None, *, phi: float | None = None
) -> Statics:
    """Leg forces, force margins and singularity margins of one pose (see :class:`Statics`).

    Parameters
    ----------
    q : array_like, shape (n, 6) or (n, 3)
        One spatial pose, or one planar pose with ``phi`` [rad].
    load : Load, optional
        As in :func:`leg_forces` (None: own weight under earth gravity).

    Returns
    -------
    Statics
    """
    qa, P, R = _pose_parts(stack, q, phi)
    if qa.ndim != 2:
        raise ValueError(f"q: expected one pose of shape (n, k), got {qa.shape}")
    f, sigma_min, condition, singular = _solve(stack, P, R, _load(load))
    fmax = stack.force_max
    absf = np.abs(f)
    limited = np.isfinite(fmax)[:, None]
    with np.errstate(invalid="ignore"):
        margin = np.where(singular[:, None], -np.inf, fmax[:, None] - absf)
        ratio = np.where(singular[:, None], np.inf, np.where(limited, absf / fmax[:, None], 0.0))
    out = (f, np.array(fmax), margin, ratio, sigma_min, condition)
    for a in out:
        a.setflags(write=False)
    flags = np.array(singular, dtype=bool)
    flags.setflags(write=False)
    return Statics(*out, length=characteristic_length(stack), singular=flags)
