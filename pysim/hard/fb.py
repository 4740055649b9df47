"""The force-biased (FB) algorithm (Mościński et al. 1989, Bezrukov et al. 2002: refs.
38, 39 of Baranau & Tallarek 2014), as the authors' code (ref. 40) implements it; the
paper gives no parameters of its own, so these are the code's.

Every sphere has its nominal diameter ``D_i`` (mean 1) and two ratios: the *outer*
``rho_out`` (the spheres of diameter ``rho_out D_i`` overlap and push each other apart)
and the *inner* ``rho_in = min_pairs |x_j - x_i| / D_ij`` (``D_ij = (D_i + D_j) / 2``:
the largest spheres that do not overlap; the packing fraction is ``phi_nominal
rho_in^3``). From the Poisson start, with ``rho_out = rho_out0 = 1.2^(1/3)`` (outer
spheres at 1.2 times the nominal packing fraction), each iteration

1. moves every sphere by ``dx_i = (eps / 2) rho_out^2 / D_i sum_j F_ij`` with the forces
   of the positions before (all at once), ``eps = 0.5``, and the pair force from ``j``
   on ``i``, along ``x_i - x_j``, of magnitude
   ``D_i D_j (1 - |x_j - x_i|^2 / (rho_out D_ij)^2)`` while the outer spheres overlap;
2. computes the forces and ``rho_in`` of the new positions;
3. shrinks the outer ratio: ``rho_out -= (1/2)^j rho_out0 gamma`` with
   ``j = ceil(-log10(1.2 phi_nominal - phi_in))`` (no shrinking while ``phi_in >= 1.2
   phi_nominal``); ``gamma`` is the FB compression rate (the paper's fast FB runs have
   ``1/gamma < 10^3``, its slow ones ``> 2 10^3``).

It ends when ``rho_out <= rho_in``; the FB density is ``phi = phi_nominal rho_in^3``.
Bezrukov et al. count ``j`` from the current nominal density (that of ``rho_out``); the
authors' code, followed here, from the initial one.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from pysim.jit import njit

#: the outer spheres start at this times the nominal packing fraction (ref. 40)
NOMINAL_DENSITY_RATIO = 1.2
#: eps of the displacement (ref. 40)
FORCE_SCALING = 0.5


def cells_per_side(side: float, dn, rho_out: float) -> int:
    """Cells per side of the force grid: cells no smaller than the largest outer
    diameter ``rho_out max(D)``, at least 3 (then every pair of the box is a candidate
    once per direction only if the box holds 3 such cells: checked by the caller)."""
    return max(int(side / (rho_out * float(np.max(dn)))), 3)


@njit
def forces(x, dn, side, rho_out, nc, f, order, start, cellof):
    """The FB forces ``f`` (N, 3) of the outer spheres of ratio ``rho_out`` (module
    docstring) and the inner ratio ``min |x_j - x_i| / D_ij`` over the pairs of
    neighbouring cells of the ``nc^3`` grid (cells no smaller than ``rho_out max(D)``:
    exact whenever some outer spheres overlap, otherwise at least ``rho_out``).
    ``order``, ``start``, ``cellof`` are work arrays (N, at least ``nc^3 + 1``, N)."""
    n = x.shape[0]
    w = side / nc
    ncell = nc * nc * nc
    start[: ncell + 1] = 0
    for i in range(n):
        cx = min(int(x[i, 0] / w), nc - 1)
        cy = min(int(x[i, 1] / w), nc - 1)
        cz = min(int(x[i, 2] / w), nc - 1)
        c = (cx * nc + cy) * nc + cz
        cellof[i] = c
        start[c + 1] += 1
    for c in range(ncell):
        start[c + 1] += start[c]
    fill = start[:ncell].copy()
    for i in range(n):
        c = cellof[i]
        order[fill[c]] = i
        fill[c] += 1
    rho_in = math.inf
    for i in range(n):
        f[i, 0] = 0.0
        f[i, 1] = 0.0
        f[i, 2] = 0.0
        c = cellof[i]
        cz = c % nc
        cy = (c // nc) % nc
        cx = c // (nc * nc)
        for ox in range(-1, 2):
            for oy in range(-1, 2):
                for oz in range(-1, 2):
                    cc = (((cx + ox) % nc) * nc + (cy + oy) % nc) * nc + (cz + oz) % nc
                    for m in range(start[cc], start[cc + 1]):
                        k = order[m]
                        if k == i:
                            continue
                        dx = x[k, 0] - x[i, 0]
                        dy = x[k, 1] - x[i, 1]
                        dz = x[k, 2] - x[i, 2]
                        dx -= side * math.floor(dx / side + 0.5)
                        dy -= side * math.floor(dy / side + 0.5)
                        dz -= side * math.floor(dz / side + 0.5)
                        d2 = dx * dx + dy * dy + dz * dz
                        dij = 0.5 * (dn[i] + dn[k])
                        q = math.sqrt(d2) / dij
                        if q < rho_in:
                            rho_in = q
                        out2 = (rho_out * dij) ** 2
                        if d2 < out2:
                            mag = dn[i] * dn[k] * (1.0 - d2 / out2) / math.sqrt(d2)
                            f[i, 0] -= mag * dx
                            f[i, 1] -= mag * dy
                            f[i, 2] -= mag * dz
    return rho_in


@njit
def displace(x, dn, side, rho_out, f):
    """Move every sphere by ``(eps / 2) rho_out^2 f_i / D_i`` and wrap it into the box."""
    s = 0.5 * FORCE_SCALING * rho_out * rho_out
    for i in range(x.shape[0]):
        for a in range(3):
            y = x[i, a] + s * f[i, a] / dn[i]
            y -= side * math.floor(y / side)
            if y >= side:  # round-off of a tiny negative coordinate
                y = 0.0
            x[i, a] = y


@dataclass
class FB:
    """State and parameters of one FB run; :meth:`step` runs ``iterations`` iterations
    (fewer at the end). The positions, forces and the work arrays live in
    :attr:`arrays`."""
    rate: float                  #: gamma
    phi_nominal: float           #: packing fraction at rho = 1
    iterations: int = 100        #: iterations per step (a row of the output)
    rho_out: float | None = None
    rho_out0: float | None = None
    rho_in: float = 0.0
    done_iterations: int = 0
    blocks: int = 0
    done: bool = False

    def __post_init__(self):
        if self.rho_out0 is None:
            self.rho_out0 = NOMINAL_DENSITY_RATIO ** (1.0 / 3.0)
        if self.rho_out is None:
            self.rho_out = self.rho_out0

    def start(self, x, dn, side) -> dict:
        """The arrays of a run from positions ``x``: the forces of the start computed.
        Raises ``ValueError`` if the box holds fewer than 3 outer diameters."""
        n = len(dn)
        if side < 3.0 * self.rho_out0 * float(np.max(dn)):
            raise ValueError(f"box side {side:.4g} holds fewer than 3 outer diameters "
                             f"{self.rho_out0 * float(np.max(dn)):.4g}; use more particles")
        a = {"x": np.array(np.mod(x, side), np.float64, order="C"),
             "dn": np.array(dn, np.float64, order="C"), "side": float(side),
             "f": np.zeros((n, 3))}
        self.rho_in = self.forces(a)
        self.done = self.rho_out <= self.rho_in
        return a

    def forces(self, a: dict) -> float:
        """Fill ``a["f"]`` with the forces at :attr:`rho_out`; returns ``rho_in``."""
        n = len(a["dn"])
        side = float(a["side"])
        nc = cells_per_side(side, a["dn"], self.rho_out)
        work = a.get("_work")
        if work is None or len(work[1]) < nc**3 + 1:
            work = (np.zeros(n, np.int64), np.zeros(nc**3 + 1, np.int64), np.zeros(n, np.int64))
            a["_work"] = work
        return float(forces(a["x"], a["dn"], side, self.rho_out, nc, a["f"], *work))

    def phi(self) -> float:
        """Packing fraction of the inner spheres, ``phi_nominal rho_in^3``."""
        return self.phi_nominal * self.rho_in**3

    def step(self, a: dict) -> int:
        """Up to :attr:`iterations` iterations (module docstring); returns how many."""
        done = 0
        dn, side = a["dn"], float(a["side"])
        while done < self.iterations and not self.done:
            displace(a["x"], dn, side, self.rho_out, a["f"])
            self.rho_in = self.forces(a)
            delta = NOMINAL_DENSITY_RATIO * self.phi_nominal - self.phi()
            if delta > 0.0:
                j = math.ceil(-math.log10(delta))
                self.rho_out -= 0.5**j * self.rho_out0 * self.rate
            done += 1
            self.done = self.rho_out <= self.rho_in
        self.done_iterations += done
        self.blocks += 1
        return done

    def to_dict(self) -> dict:
        return asdict(self)
