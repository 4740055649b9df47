"""Constructed packings shared by the analysis tests."""
import numpy as np

from analysis.frame import Frame


def frame_of(x, radius, box, periodic=(True, True, True), axis=None, length=None, dimension=None):
    return Frame.from_arrays(x, radius, box, axis=axis, length=length, periodic=periodic,
                             dimension=dimension)


def cubic(m, spacing=1.0, offset=0.0, shape=None):
    """Simple cubic lattice points (m^3, 3) or a box of ``shape`` = (mx, my, mz)."""
    mx, my, mz = shape if shape is not None else (m, m, m)
    g = [np.arange(k) * spacing + offset for k in (mx, my, mz)]
    return np.array(np.meshgrid(*g, indexing="ij")).reshape(3, -1).T


def square(m, spacing=1.0, offset=0.0):
    """Square lattice (m^2, 3) at z = 0."""
    g = np.arange(m) * spacing + offset
    xy = np.array(np.meshgrid(g, g, indexing="ij")).reshape(2, -1).T
    return np.column_stack([xy, np.zeros(len(xy))])


def random_unit(rng, n, dim=3):
    u = rng.normal(size=(n, 3))
    if dim == 2:
        u[:, 2] = 0.0
    return u / np.linalg.norm(u, axis=1)[:, None]
