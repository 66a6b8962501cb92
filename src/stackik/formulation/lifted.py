"""The lifted planar IK problem: chain states as variables, every matrix O(n) sparse.

DESIGN §8, the multiple-shooting idea along the stack. Besides each platform's
``p_i = (rho_i, z_i)`` and ``theta_i`` the variables hold, for ``j = 1..n-1``, the
vector ``D_j = P_ee - O_j`` from plate j's origin to the end effector and the cumulative
angle ``Theta_j = theta_1 + ... + theta_j``, tied by the chain equalities (``D_0`` = the
target position, ``D_n = 0``, ``Theta_0 = 0``, ``Theta_n`` = the target angle)::

    b_j = D_{j-1} - D_j - Rot(Theta_{j-1}) p_j = 0        (2 rows, j = 1..n)
    a_j = Theta_j - Theta_{j-1} - theta_j = 0             (1 row,  j = 1..n)

so that the end-effector equalities are part of the chain and ``FN^2 = 3n + sum |D_j|^2``
is a separable quadratic (diagonal Hessian). The constraint Jacobian is banded (row block
j touches blocks j-1 and j), the 24 limits of platform i touch its 3 variables, and the
Lagrangian Hessian is the objective's diagonal plus one 3x3 block per chain equality
(``Theta_{j-1}, p_j``) and per platform's limits (``p_i, theta_i``): O(n) nonzeros, O(n)
work for a sparse LDL' factorisation. Same solutions as the reduced problem
(:class:`~stackik.formulation.Problem`): :meth:`LiftedPlanarNLP.lift` and
:meth:`LiftedPlanarNLP.reduce` map between the two.

Variables (scaled like :class:`Problem`: lengths / L, angles in rad), platform-major: block
i (0-based, i < n-1) is ``[rho, z, theta, D_x, D_z, Theta]`` of platform i+1 and the last
block ``[rho, z, theta]``: ``6n - 3`` in all. Equalities: ``[b_j; a_j]`` per j (``3n``),
scaled like the reduced problem's (lengths / L). Inequalities: the reduced problem's limits.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.formulation.problem import Problem
from stackik.kinematics import _planar_parts
from stackik.sqp.sparse import csc
from stackik.targets import PlanarTarget

__all__ = ["LiftedPlanarNLP"]

FloatArray = NDArray[np.float64]


def _csc(data: FloatArray, indices: Any, indptr: Any, shape: tuple[int, int]) -> Any:
    return csc(data, indices, indptr, shape)


class _Pattern:
    """A fixed CSC pattern from (row, col) entry lists, and the scatter of values."""

    def __init__(self, rows: Any, cols: Any, shape: tuple[int, int]) -> None:
        m, n = shape
        keys = np.asarray(cols, dtype=np.int64) * m + np.asarray(rows, dtype=np.int64)
        uniq, inv = np.unique(keys, return_inverse=True)
        self.shape = shape
        self.inv = inv  # entry k of the lists -> position in the pattern (duplicates add)
        self.indices = (uniq % m).astype(np.int32)
        self.indptr = np.searchsorted(uniq // m, np.arange(n + 1)).astype(np.int32)
        self.nnz = int(uniq.size)

    def matrix(self, values: FloatArray) -> Any:
        data = np.asarray(np.bincount(self.inv, weights=values, minlength=self.nnz), float)
        return _csc(data, self.indices, self.indptr, self.shape)


@dataclass(frozen=True)
class _Index:
    """Positions of the lifted variables: block i (i < n-1) is
    ``[rho, z, theta, D_x, D_z, Theta]`` of platform i+1, the last block ``[rho, z, theta]``."""

    rho: NDArray[np.int64]  # (n,)
    z: NDArray[np.int64]
    th: NDArray[np.int64]
    dx: NDArray[np.int64]  # (n-1,)
    dz: NDArray[np.int64]
    Th: NDArray[np.int64]
    p: NDArray[np.int64]  # (n, 2): rho, z
    D: NDArray[np.int64]  # (n-1, 2): D_x, D_z

    @classmethod
    def of(cls, n: int) -> _Index:
        i = np.arange(n)
        j = np.arange(n - 1)
        rho, z, th = 6 * i, 6 * i + 1, 6 * i + 2
        dx, dz, Th = 6 * j + 3, 6 * j + 4, 6 * j + 5
        return cls(
            rho, z, th, dx, dz, Th, np.stack([rho, z], axis=1), np.stack([dx, dz], axis=1)
        )  # fmt: skip


@dataclass(frozen=True)
class _Patterns:
    """The fixed sparsity patterns of the lifted problem's matrices."""

    eq: _Pattern  # equality Jacobian (3n, nv)
    in_indptr: NDArray[np.int32]  # limit Jacobian (24n, nv), CSC: its indptr and indices
    in_indices: NDArray[np.int32]
    hessian: _Pattern  # Lagrangian Hessian (nv, nv)

    @classmethod
    def build(cls, ix: _Index, n: int, nv: int) -> _Patterns:
        """The patterns; values are scattered in the order of the entry lists built here
        (:meth:`LiftedPlanarNLP.evaluate`, :meth:`LiftedPlanarNLP.hessian`)."""
        rows: list[Any] = []
        cols: list[Any] = []
        # equality rows: block j (0-based) = [b_j (2 rows), a_j (1 row)] at 3j .. 3j+2
        jb = np.arange(n)
        for k in range(2):
            r = 3 * jb + k
            # -Rot(Theta_{j-1}) p_j: both p columns
            for c in range(2):
                rows.append(r)
                cols.append(ix.p[:, c])
            # +D_{j-1} (j >= 1)
            rows.append(r[1:])
            cols.append(ix.D[:, k])
            # -D_j (j <= n-2)
            rows.append(r[:-1])
            cols.append(ix.D[:, k])
            # -Rot'(Theta_{j-1}) p_j (j >= 1)
            rows.append(r[1:])
            cols.append(ix.Th)
        ra = 3 * jb + 2
        rows += [ra[:-1], ra[1:], ra]
        cols += [ix.Th, ix.Th, ix.th]
        eq = _Pattern(np.concatenate(rows), np.concatenate(cols), (3 * n, nv))
        # limits: rows 24 i .. 24 i + 23, columns (rho_i, z_i, theta_i), CSC order
        blk = np.stack([ix.rho, ix.z, ix.th], axis=1)  # (n, 3)
        in_indptr = np.zeros(nv + 1, dtype=np.int32)
        counts = np.zeros(nv, dtype=np.int64)
        counts[blk.ravel()] = 24
        np.cumsum(counts, out=in_indptr[1:])
        in_indices = (
            (24 * np.arange(n)[:, None, None] + np.arange(24)[None, None, :])
            .repeat(3, axis=1)
            .ravel()
            .astype(np.int32)
        )
        # Hessian: limits' 3x3 per platform, chain's 3x3 on (Theta_{j-1}, rho_j, z_j),
        # the objective's diagonal on D, and the whole diagonal
        hr: list[Any] = []
        hc: list[Any] = []
        cb = np.concatenate([ix.Th[:, None], ix.p[1:]], axis=1)  # (n-1, 3)
        for block in (blk, cb):
            for a in range(3):
                for b in range(3):
                    hr.append(block[:, a])
                    hc.append(block[:, b])
        hr.append(np.arange(nv))
        hc.append(np.arange(nv))
        hessian = _Pattern(np.concatenate(hr), np.concatenate(hc), (nv, nv))
        return cls(eq, in_indptr, in_indices, hessian)


class LiftedPlanarNLP:
    """``(f, g, c_E, J_E, c_I, J_I)`` and the exact Lagrangian Hessian of the lifted
    problem (all sparse, fixed patterns), for :class:`stackik.sqp.NonlinearProgram`."""

    def __init__(self, prob: Problem, psd_blocks: bool = False) -> None:
        if prob.fast is None or not isinstance(prob.target, PlanarTarget):
            raise ValueError("LiftedPlanarNLP is planar only")
        if prob.objective not in ("frobenius", "feasible", "weighted"):
            raise ValueError(f"unknown objective {prob.objective!r}")
        self.prob = prob
        self.fast = prob.fast
        self.psd_blocks = psd_blocks
        n = prob.n
        self.n = n
        self.nv = 6 * n - 3
        L = prob.L
        self.L = L
        t = prob.target
        self.y_t = np.array([t.rho, t.z]) / L  # D_0, scaled
        self.theta_t = float(t.theta)
        self.ix = _Index.of(n)
        # objective f = c0/fscale + sum_j wD_j |D_j|^2 (D scaled by L)
        if prob.objective == "feasible":
            self.wD = np.zeros(n - 1)
        else:
            self.wD = (L * L / prob.fscale) * prob.rw[0::2] ** 2  # rw repeats per (x, z)
        self.c_rows = prob.cs.size  # 24 n
        self.patterns = _Patterns.build(self.ix, n, self.nv)
        self._u: FloatArray | None = None
        self._out: tuple[Any, ...] = ()

    @property
    def h_pat(self) -> _Pattern:
        """The Lagrangian Hessian's fixed pattern."""
        return self.patterns.hessian

    # --- maps between the formulations --------------------------------------------------
    def lift(self, u: FloatArray) -> FloatArray:
        """Lifted point of the reduced scaled point ``u`` (chain equalities exact except
        the end effector's: ``D_0``, ``Theta_n`` carry the target's error)."""
        p = self.prob
        q = p.q_of(u)
        n = self.n
        Theta, _, O = _planar_parts(q)
        x = np.zeros(self.nv)
        x[self.ix.rho] = u[0::3]
        x[self.ix.z] = u[1::3]
        x[self.ix.th] = u[2::3]
        D = (O[-1] - O[1:n]) / self.L  # D_1 .. D_{n-1}
        x[self.ix.dx] = D[:, 0]
        x[self.ix.dz] = D[:, 1]
        x[self.ix.Th] = Theta[1:]  # Theta_j = theta_1 + ... + theta_j
        return x

    def reduce(self, x: FloatArray) -> FloatArray:
        """The reduced scaled point (``rho, z, theta`` of every platform)."""
        u = np.empty(3 * self.n)
        u[0::3] = x[self.ix.rho]
        u[1::3] = x[self.ix.z]
        u[2::3] = x[self.ix.th]
        return u

    # --- evaluation -----------------------------------------------------------------------
    def _chain(self, x: FloatArray) -> tuple[FloatArray, ...]:
        n = self.n
        Th_prev = np.concatenate(([0.0], x[self.ix.Th]))  # Theta_{j-1}, j = 1..n
        c, s = np.cos(Th_prev), np.sin(Th_prev)
        p = x[self.ix.p]  # (n, 2)
        Rp = np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]], axis=1)
        D = np.zeros((n + 1, 2))
        D[0] = self.y_t
        D[1:n, 0] = x[self.ix.dx]
        D[1:n, 1] = x[self.ix.dz]
        return Th_prev, c, s, p, Rp, D

    def evaluate(self, x: FloatArray) -> tuple[Any, ...]:
        if self._u is not None and np.array_equal(x, self._u):
            return self._out
        n = self.n
        Th_prev, c, s, p, Rp, D = self._chain(x)
        Theta = np.concatenate((x[self.ix.Th], [self.theta_t]))  # Theta_j, j = 1..n
        ceq = np.empty(3 * n)
        b = D[:-1] - D[1:] - Rp  # (n, 2)
        ceq[0::3] = b[:, 0]
        ceq[1::3] = b[:, 1]
        ceq[2::3] = Theta - Th_prev - x[self.ix.th]
        # Jacobian values in the order of the entry lists of _Patterns.build
        # d(-Rot p)/dp = -Rot = [[-c, s], [-s, -c]]; d(-Rot p)/dTheta = -Rot' p
        dRp = np.stack([-s * p[:, 0] - c * p[:, 1], c * p[:, 0] - s * p[:, 1]], axis=1)
        vals = []
        for k in range(2):
            if k == 0:
                vals += [-c, s]
            else:
                vals += [-s, -c]
            vals.append(np.ones(n - 1))
            vals.append(-np.ones(n - 1))
            vals.append(-dRp[1:, k])
        vals += [np.full(n - 1, 1.0), np.full(n - 1, -1.0), np.full(n, -1.0)]
        # a_j: +Theta_j (j <= n-1), -Theta_{j-1} (j >= 2), -theta_j
        Jeq = self.patterns.eq.matrix(np.concatenate(vals))
        q = self.prob.q_of(self.reduce(x))
        cin, Jin_red = self.fast.sparse(q)
        pat = self.patterns
        Jin = _csc(Jin_red.data, pat.in_indices, pat.in_indptr, (self.c_rows, self.nv))
        g = np.zeros(self.nv)
        Dj = D[1:n]
        f = self.prob.c0 / self.prob.fscale if self.prob.objective != "feasible" else 0.0
        f += float(np.sum(self.wD[:, None] * Dj * Dj))
        g[self.ix.dx] = 2.0 * self.wD * Dj[:, 0]
        g[self.ix.dz] = 2.0 * self.wD * Dj[:, 1]
        self._u = x.copy()
        self._out = (f, g, ceq, Jeq, cin, Jin)
        return self._out

    def hessian(self, x: FloatArray, y_eq: FloatArray, y_in: FloatArray) -> Any:
        """Exact Hessian of ``f - y_eq.c_E - y_in.c_I`` (CSC, fixed pattern)."""
        n = self.n
        Th_prev, c, s, p, Rp, D = self._chain(x)
        q = self.prob.q_of(self.reduce(x))
        Hl = self.fast.constraint_hessian_blocks(q, y_in * self.prob.cs)  # (n, 3, 3)
        xs3 = np.array([self.L, self.L, 1.0])
        Hl = -Hl * np.outer(xs3, xs3)[None]
        # chain b_j, j >= 2 (0-based j >= 1): variables (Theta_{j-1}, rho_j, z_j)
        yb = np.stack([y_eq[0::3], y_eq[1::3]], axis=1)[1:]  # (n-1, 2)
        cc, ss = c[1:], s[1:]
        Rp1 = Rp[1:]
        Hc = np.zeros((n - 1, 3, 3))
        # d2 b/dTheta2 = +Rot p  -> -y.Rp
        Hc[:, 0, 0] = -(yb * Rp1).sum(axis=1)
        # d2 b/dTheta dp = -Rot'  (Rot' = [[-s, -c], [c, -s]]) -> +y' Rot'
        Hc[:, 0, 1] = yb[:, 0] * -ss + yb[:, 1] * cc
        Hc[:, 0, 2] = yb[:, 0] * -cc + yb[:, 1] * -ss
        Hc[:, 1, 0] = Hc[:, 0, 1]
        Hc[:, 2, 0] = Hc[:, 0, 2]
        if self.psd_blocks:
            Hl, Hc = _psd(Hl), _psd(Hc)
        diag = np.zeros(self.nv)
        diag[self.ix.dx] = 2.0 * self.wD
        diag[self.ix.dz] = 2.0 * self.wD
        vals = np.concatenate(
            [Hl[:, a, b] for a in range(3) for b in range(3)]
            + [Hc[:, a, b] for a in range(3) for b in range(3)]
            + [diag]
        )
        return self.patterns.hessian.matrix(vals)


def _psd(blocks: FloatArray) -> FloatArray:
    """Each symmetric block with its negative eigenvalues set to zero."""
    w, V = np.linalg.eigh(blocks)
    B = np.einsum("kij,kj,klj->kil", V, np.maximum(w, 0.0), V)
    return 0.5 * (B + B.transpose(0, 2, 1))  # type: ignore[no-any-return]
