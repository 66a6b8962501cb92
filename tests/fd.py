"""Numerical derivatives for the derivative tests, with tolerances derived from the step and
the function's scale (so that they hold on any CPU, not only on the one they were tuned on).

Scale model
-----------
``F`` is the function's scale: the size of the terms that make up the value of f (lengths of
the stack in mm, squared lengths for FN^2, ...), which may be much larger than ``|f|`` when
terms cancel. ``X = max(|x_a|, typical_a)`` is the scale of variable a: the distance over
which f changes by about F. Then the k-th derivative along a is of size ``~ F / X^k``.

Central differences (``central``)
---------------------------------
With the step ``h = eps^(1/3) X`` (made exactly representable, ``h = (x + h) - x``),

    D_h = (f(x + h e_a) - f(x - h e_a)) / (2 h) = f'(x) + h^2/6 f'''(x) + O(h^4)

and ``|D_h - f'| <= truncation + rounding`` with

* truncation ``h^2/6 M3``: M3 is the larger of the model ``F / X^3`` and the third derivative
  measured by Richardson's difference ``D_2h - D_h = h^2/2 f''' + O(h^4)`` (so a function
  that curves more than its scale suggests, e.g. a polynomial test problem, is covered);
* rounding ``ulps * eps * F / h``: each value of f is accurate to ``ulps * eps * F``
  (``ulps`` counts the roundings that accumulate into the value, ``eps`` the machine
  epsilon) and the difference of two such values is divided by ``2 h``.

The analytic derivative carries its own rounding, ``ulps * eps * F / X``. The check is

    |analytic - numeric| <= safety * (truncation + rounding + analytic rounding)

element by element; ``safety`` covers the order-one constants the scale model leaves out
(a derivative may exceed ``F / X^k`` by a small factor, sums of many terms round more).
``h = eps^(1/3) X`` nearly minimises ``h^2/6 F/X^3 + eps F/h`` (the minimum is at
``(3 eps)^(1/3) X``); the bound is then ``~ safety * ulps * eps^(2/3) F / X``, about
``6e-9 F / X`` with the defaults: a relative test of the derivative that no rounding on any
CPU can reach, and that any error in an analytic formula fails by orders of magnitude.

Richardson extrapolation (``central(..., richardson=True)``)
-------------------------------------------------------------
``R_h = (4 D_h - D_2h) / 3 = f' - h^4/30 f^(5) + ...`` with step ``h = eps^(1/5) X``:
truncation ``h^4/30 M5`` (M5 the larger of ``F / X^5`` and ``|R_2h - R_h| / 15``), rounding
``(4/3 + 1/6) ulps eps F / h = 1.5 ulps eps F / h``; the bound is ``~ eps^(4/5) F / X``, a
hundred times tighter than central differences, at three times the evaluations.

Complex step (``complex_step``)
-------------------------------
For functions written with analytic operations only (``reference_impl``; not stackik, which
casts to float): ``Im f(x + i h) / h`` with ``h = 1e-30 X`` has no subtraction, so its error is
rounding only, ``ulps * eps * F / X`` (truncation ``h^2/6 F/X^3`` underflows to nothing).

Set ``FD_RATIO_LOG`` to a file name to append ``test<TAB>what<TAB>worst error/bound`` for
every check (used to confirm that no tolerance is marginal across seeds and CPUs).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

EPS = float(np.finfo(float).eps)  # 2.2e-16
SAFETY = 10.0  # order-one constants the scale model leaves out
ULPS = 16.0  # rounding of one evaluation of f (or of the analytic derivative), in eps * F
COMPLEX_STEP = 1e-30  # relative to X


@dataclass(frozen=True)
class Numeric:
    """A numerical derivative and what its error bound needs.

    value: shape ``f(x).shape + x.shape``; h, x_scale: shape ``x.shape``; measured: the
    truncation error measured by Richardson's difference (shape of value), or None.
    """

    value: np.ndarray
    h: np.ndarray
    x_scale: np.ndarray
    method: str  # "central", "richardson" or "complex-step"
    measured: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, ...]:
        return self.value.shape


def variable_scale(x, typical=1.0) -> np.ndarray:
    """``X = max(|x|, typical)`` elementwise (typical broadcasts against x, e.g. per column)."""
    x = np.asarray(x, dtype=float)
    return np.maximum(np.abs(x), np.broadcast_to(np.asarray(typical, dtype=float), x.shape))


def derivative_scale(F, X, k: int = 1) -> np.ndarray:
    """Scale of the k-th derivative of a function of scale F (any shape) in variables of
    scale X: ``F / (X_a X_b ...)``, shape ``F.shape + X.shape * k``.

    E.g. the rows of a gradient are of scale ``F / X_a``: pass ``derivative_scale(F, X)`` as
    the f_scale of a Hessian obtained by differencing the gradient.
    """
    out = np.asarray(F, dtype=float)
    inv = 1.0 / np.asarray(X, dtype=float)
    for _ in range(k):
        out = np.multiply.outer(out, inv)
    return out


def term_scale(f0, numeric: Numeric) -> np.ndarray:
    """F for a function without a physical scale (test problems): ``|f_i(x)| + sum_a X_a
    |df_i/dx_a|``, the size of the terms of f_i under a first-order model (terms of that
    size may cancel in f_i(x)). Shape of f; from the numerical derivative, not the analytic.
    """
    f0 = np.abs(np.asarray(f0, dtype=float))
    axes = tuple(range(f0.ndim, numeric.value.ndim))
    first = np.sum(np.abs(numeric.value) * numeric.x_scale, axis=axes)
    return np.maximum(f0 + first, np.finfo(float).tiny)


def central(f, x, *, typical=1.0, richardson: bool = False, rel_step: float | None = None):
    """Derivative of f at x (any shapes) by central differences, shape f(x).shape + x.shape.

    The step of variable a is ``rel_step * max(|x_a|, typical_a)``, rel_step ``eps^(1/3)``
    (``eps^(1/5)`` with Richardson extrapolation), rounded to be exactly representable.
    f is evaluated at x +- h, x +- 2h (and +- 4h with richardson) along each variable.
    """
    x = np.asarray(x, dtype=float)
    X = variable_scale(x, typical)
    if rel_step is None:
        rel_step = EPS ** (1 / 5) if richardson else EPS ** (1 / 3)
    shape = np.asarray(f(x)).shape + x.shape
    mults = (1, 2, 4) if richardson else (1, 2)
    D = {m: np.zeros(shape) for m in mults}
    H = np.zeros(x.shape)
    for idx in np.ndindex(*x.shape):
        h = float((x[idx] + rel_step * X[idx]) - x[idx])  # exactly representable
        H[idx] = h
        for m in mults:
            xp, xm = x.copy(), x.copy()
            xp[idx] += m * h
            xm[idx] -= m * h
            df = np.asarray(f(xp), dtype=float) - np.asarray(f(xm), dtype=float)
            D[m][(Ellipsis,) + idx] = df / (xp[idx] - xm[idx])
    if not richardson:
        return Numeric(D[1], H, X, "central", np.abs(D[2] - D[1]) / 3.0)
    R1 = (4.0 * D[1] - D[2]) / 3.0
    R2 = (4.0 * D[2] - D[4]) / 3.0
    return Numeric(R1, H, X, "richardson", np.abs(R2 - R1) / 15.0)


def complex_step(f, x, *, typical=1.0):
    """Derivative of a complex-safe f at the real x, ``Im f(x + i h) / h``, h = 1e-30 X."""
    x = np.asarray(x, dtype=float)
    X = variable_scale(x, typical)
    shape = np.asarray(f(x)).shape + x.shape
    out = np.zeros(shape)
    H = COMPLEX_STEP * X
    for idx in np.ndindex(*x.shape):
        xc = x.astype(complex)
        xc[idx] += 1j * H[idx]
        out[(Ellipsis,) + idx] = np.imag(np.asarray(f(xc))) / H[idx]
    return Numeric(out, H, X, "complex-step", None)


def error_bound(numeric: Numeric, f_scale, *, safety=SAFETY, ulps=ULPS):
    """The elementwise bound on |analytic - numeric| and its parts (see the module doc).

    f_scale: F, a scalar or an array broadcastable to the shape of f (e.g. one scale per
    output row). Returns ``(bound, parts)`` with parts a dict of arrays of the value's shape.
    """
    h = np.asarray(numeric.h, dtype=float)
    shape = numeric.value.shape
    out_shape = shape[: len(shape) - h.ndim]
    F = np.broadcast_to(np.asarray(f_scale, dtype=float), out_shape)
    F = F.reshape(out_shape + (1,) * h.ndim)
    if not np.all(F > 0) or not np.all(np.isfinite(F)):
        raise ValueError("f_scale must be positive and finite")
    X = np.asarray(numeric.x_scale, dtype=float)
    if numeric.method == "central":
        model = h**2 / 6.0 * F / X**3
        rounding = ulps * EPS * F / h
    elif numeric.method == "richardson":
        model = h**4 / 30.0 * F / X**5
        rounding = 1.5 * ulps * EPS * F / h
    elif numeric.method == "complex-step":
        model = h**2 / 6.0 * F / X**3
        rounding = ulps * EPS * F / X
    else:
        raise ValueError(numeric.method)
    measured = np.zeros(shape) if numeric.measured is None else numeric.measured
    truncation = np.maximum(np.broadcast_to(model, shape), measured)
    rounding = np.broadcast_to(rounding, shape)
    analytic = np.broadcast_to(ulps * EPS * F / X, shape)
    bound = safety * (truncation + rounding + analytic)
    parts = {
        "model truncation": np.broadcast_to(model, shape),
        "measured truncation": measured,
        "rounding": rounding,
        "analytic rounding": analytic,
        "F": np.broadcast_to(F, shape),
        "X": np.broadcast_to(X, shape),
        "h": np.broadcast_to(h, shape),
    }
    return bound, parts


_FORMULAS = {
    "central": "model truncation = h^2/6 * F/X^3, measured = |D_2h - D_h|/3, "
    "rounding = ulps*eps*F/h, h = eps^(1/3)*X",
    "richardson": "model truncation = h^4/30 * F/X^5, measured = |R_2h - R_h|/15, "
    "rounding = 1.5*ulps*eps*F/h, h = eps^(1/5)*X",
    "complex-step": "truncation = h^2/6 * F/X^3 (h = 1e-30*X), rounding = ulps*eps*F/X",
}


def assert_derivative_close(
    analytic, numeric: Numeric, *, f_scale, safety=SAFETY, ulps=ULPS, what=""
) -> float:
    """Assert ``|analytic - numeric| <= bound`` elementwise; return the worst error/bound.

    analytic: the derivative under test, shape ``numeric.shape`` (reshape it to
    ``f.shape + x.shape`` first). f_scale: see :func:`error_bound`.
    """
    analytic = np.asarray(analytic, dtype=float)
    assert analytic.shape == numeric.shape, (what, analytic.shape, numeric.shape)
    bound, parts = error_bound(numeric, f_scale, safety=safety, ulps=ulps)
    err = np.abs(analytic - numeric.value)
    ratio = np.where(np.isfinite(err), err / bound, np.inf)
    worst = float(ratio.max(initial=0.0))
    log = os.environ.get("FD_RATIO_LOG")
    if log:
        test = os.environ.get("PYTEST_CURRENT_TEST", "?").split(" ")[0]
        with open(log, "a", encoding="utf-8") as fh:
            fh.write(f"{test}\t{what}\t{worst:.3e}\n")
    if worst <= 1.0:
        return worst
    i = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    detail = ", ".join(f"{k} {v[i]:.3e}" for k, v in parts.items())
    raise AssertionError(
        f"{what}: |analytic - numeric| = {err[i]:.3e} > bound {bound[i]:.3e} at {i} "
        f"(analytic {analytic[i]:.9e}, numeric {numeric.value[i]:.9e}; "
        f"{int(np.sum(ratio > 1))} of {ratio.size} elements exceed their bound)\n"
        f"  bound = safety {safety:g} * (max(model, measured truncation) + rounding "
        f"+ analytic rounding), {numeric.method}: {_FORMULAS[numeric.method]}, "
        f"analytic rounding = ulps*eps*F/X, ulps {ulps:g}, eps {EPS:.3e}\n"
        f"  at {i}: {detail}"
    )


# ----------------------------------------------------------------------- stackik's scales
MM = 100.0  # typical translation [mm] (platforms are 200-450 mm tall, 100-200 mm wide)
TYPICAL_PLANAR = (MM, MM, 1.0)  # per column of a planar pose (rho, z, theta)
TYPICAL_SPATIAL = (MM, MM, MM, 1.0, 1.0, 1.0)  # (x, y, z, yaw, pitch, roll)


def chain_length(q) -> float:
    """``1 + sum_i |t_i|`` [mm] for a pose q (n, 3) planar or (n, 6) spatial: bounds the
    distance between any two plate origins, hence every position in the stack."""
    q = np.asarray(q, dtype=float)
    t = q[:, :2] if q.shape[1] == 3 else q[:, :3]
    return 1.0 + float(np.sum(np.linalg.norm(t, axis=1)))


def constraint_scale(top, base, leg_max, q) -> np.ndarray:
    """F of the 24 constraints of each platform, shape (n, 24).

    top, base: (n, 6, 3) nodes [mm]; leg_max: (n,); q: (n, 3) planar or (n, 6) spatial.
    A leg vector is at most ``lam = |t_i| + max |top_i| + max |base_i|`` long, so the leg
    blocks (``|l|^2 - limit^2`` [mm^2]) are of scale ``lam^2 + leg_max^2`` and the joint
    blocks (``l.n - |l| sin`` [mm]) of scale ``lam``.
    """
    q = np.asarray(q, dtype=float)
    t = q[:, :2] if q.shape[1] == 3 else q[:, :3]
    lam = (
        np.linalg.norm(t, axis=1)
        + np.linalg.norm(np.asarray(top, dtype=float), axis=2).max(axis=1)
        + np.linalg.norm(np.asarray(base, dtype=float), axis=2).max(axis=1)
    )
    legs = lam**2 + np.asarray(leg_max, dtype=float) ** 2
    return np.concatenate([np.repeat(legs[:, None], 12, 1), np.repeat(lam[:, None], 12, 1)], 1)


def block_diagonal(Jc) -> np.ndarray:
    """Per-platform blocks (n, 24, k) -> the full (n, 24, n, k): platform i's constraints
    depend on q_i only, so the numerical derivative's off-diagonal blocks must vanish."""
    Jc = np.asarray(Jc, dtype=float)
    return np.einsum("icj,im->icmj", Jc, np.eye(Jc.shape[0]))
