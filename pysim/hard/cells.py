"""Cell grids of the hard-sphere kernels: the periodic cube of side ``L`` cut into
``nc^3`` cells of side ``w = L / nc`` no smaller than a reach, so that two points closer
than the reach lie in the same or neighbouring cells (the 27 around a point's own).
Each point's cell id is kept in ``cell[i]`` and in a doubly linked list per cell
(``head``, ``nxt``, ``prv``), so a point can move to another cell in ``O(1)``. With at
least 3 cells per side the 27 neighbouring cells are distinct and every pair within the
reach is within half the box: the minimum image is the pair's only close image.
"""
from __future__ import annotations

import math

import numpy as np

from pysim.jit import inline_njit, njit

#: fewest cells per side
MIN_CELLS = 3


class GridError(ValueError):
    """The box is too small for the grid of the largest reach; the message is one line."""


def max_cells(side: float, n: int) -> int:
    """Cells per side at most for ``n`` points: about 2 cells per point at low density
    (short reaches would ask for more cells than points)."""
    return max(MIN_CELLS, int(math.ceil(2.0 * n ** (1.0 / 3.0))))


def cells_per_side(side: float, reach: float, nc_max: int) -> int:
    """Cells per side whose cells are no smaller than ``reach``, at most ``nc_max``;
    raises :class:`GridError` below :data:`MIN_CELLS`."""
    nc = int(math.floor(side / reach))
    if nc < MIN_CELLS:
        raise GridError(f"box side {side:.4g} holds only {nc} cells of the reach {reach:.4g} "
                        f"(largest contact distance and skin) per side; use more particles "
                        f"(at least {MIN_CELLS} cells per side)")
    return min(nc, nc_max)


@inline_njit
def cell_of(x0, x1, x2, w, nc):
    """Cell id of a point in ``[0, nc w)^3``."""
    cx = min(max(int(x0 / w), 0), nc - 1)
    cy = min(max(int(x1 / w), 0), nc - 1)
    cz = min(max(int(x2 / w), 0), nc - 1)
    return (cx * nc + cy) * nc + cz


@inline_njit
def neighbour_cell(c, ox, oy, oz, nc):
    """Id of the cell at offset ``(ox, oy, oz)`` from cell ``c`` (periodic)."""
    cz = c % nc
    cy = (c // nc) % nc
    cx = c // (nc * nc)
    return (((cx + ox) % nc) * nc + (cy + oy) % nc) * nc + (cz + oz) % nc


@inline_njit
def insert(c, i, head, nxt, prv):
    """Put point ``i`` at the front of cell ``c``'s list."""
    h = head[c]
    nxt[i] = h
    prv[i] = -1
    if h >= 0:
        prv[h] = i
    head[c] = i


@inline_njit
def remove(c, i, head, nxt, prv):
    """Take point ``i`` out of cell ``c``'s list."""
    a = prv[i]
    b = nxt[i]
    if a >= 0:
        nxt[a] = b
    else:
        head[c] = b
    if b >= 0:
        prv[b] = a


@njit
def build(x, nc, side, cell, head, nxt, prv):
    """Sort every point (rows of ``x``, in ``[0, side)``) into its cell of the ``nc^3``
    grid (``head`` holds at least ``nc^3`` entries)."""
    w = side / nc
    head[: nc * nc * nc] = -1
    for i in range(x.shape[0]):
        c = cell_of(x[i, 0], x[i, 1], x[i, 2], w, nc)
        cell[i] = c
        insert(c, i, head, nxt, prv)


def empty(n: int, nc_max: int):
    """``(cell, head, nxt, prv)`` arrays for ``n`` points and up to ``nc_max^3`` cells."""
    return (np.zeros(n, np.int64), np.full(nc_max**3, -1, np.int64), np.full(n, -1, np.int64),
            np.full(n, -1, np.int64))
