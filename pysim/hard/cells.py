"""The cell grid of the event-driven dynamics: the periodic cube of side ``L`` cut into
``nc^3`` cells of side ``w = L / nc`` no smaller than the largest diameter the run may
reach, so that two spheres can touch only from the same or neighbouring cells (the 27
around a particle's own). Each particle's cell is kept in ``cell[i]`` (integer
coordinates) and in a doubly linked list per cell (``head``, ``nxt``, ``prv``); a particle
changes cell at a *transfer* event, when it reaches a face of its cell (Lubachevsky
1991, ref. 37). At least 4 cells per side keep every pair of neighbouring cells within
half the box, so the minimum image is the pair's only image that can touch.
"""
from __future__ import annotations

import math

import numpy as np

from pysim.jit import inline_njit, njit

#: fewest cells per side: neighbouring cells then lie within half the box
MIN_CELLS = 4


class GridError(ValueError):
    """The box is too small for the grid of the largest diameter; the message is one line."""


def cells_per_side(side: float, reach: float) -> int:
    """Cells per side of a cube of side ``side`` whose cells are no smaller than
    ``reach`` (the largest diameter the run may reach); raises :class:`GridError` below
    :data:`MIN_CELLS`."""
    nc = int(math.floor(side / reach))
    if nc < MIN_CELLS:
        raise GridError(f"box side {side:.4g} holds only {nc} cells of the largest diameter "
                        f"{reach:.4g} per side; use more particles (at least {MIN_CELLS} "
                        "cells per side)")
    return nc


@inline_njit
def cell_id(cx, cy, cz, nc):
    return (cx * nc + cy) * nc + cz


@inline_njit
def insert(c, i, head, nxt, prv):
    """Put particle ``i`` at the front of cell ``c``'s list."""
    h = head[c]
    nxt[i] = h
    prv[i] = -1
    if h >= 0:
        prv[h] = i
    head[c] = i


@inline_njit
def remove(c, i, head, nxt, prv):
    """Take particle ``i`` out of cell ``c``'s list."""
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
    """Sort every particle (positions ``x`` in ``[0, side)``) into its cell."""
    w = side / nc
    head[:] = -1
    for i in range(x.shape[0]):
        for a in range(3):
            k = int(x[i, a] / w)
            cell[i, a] = min(max(k, 0), nc - 1)
        insert(cell_id(cell[i, 0], cell[i, 1], cell[i, 2], nc), i, head, nxt, prv)


@inline_njit
def transfer_time(x, v, cell, i, w):
    """``(tau, face)``: time until particle ``i`` (at ``x[i]`` now, velocity ``v[i]``)
    reaches a face of its cell, and which: ``2 a`` the lower face on axis ``a``, ``2 a +
    1`` the upper; ``(inf, -1)`` at rest. Round-off can put a particle a hair past its
    face: it then leaves at once (``tau = 0``)."""
    best = math.inf
    face = -1
    for a in range(3):
        va = v[i, a]
        if va > 0.0:
            tau = ((cell[i, a] + 1) * w - x[i, a]) / va
            up = 1
        elif va < 0.0:
            tau = (cell[i, a] * w - x[i, a]) / va
            up = 0
        else:
            continue
        if tau < 0.0:
            tau = 0.0
        if tau < best:
            best = tau
            face = 2 * a + up
    return best, face


def empty(n: int, nc: int):
    """``(cell, head, nxt, prv)`` arrays for ``n`` particles and ``nc^3`` cells."""
    return (np.zeros((n, 3), np.int64), np.full(nc**3, -1, np.int64), np.full(n, -1, np.int64),
            np.full(n, -1, np.int64))
