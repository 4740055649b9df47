"""Random non-overlapping initial configurations (made once, shared by all engines).

Random sequential addition (RSA) of spheres into a periodic box: each sphere is
tried at uniformly random positions until it overlaps none of those already
placed. Spheres are placed largest first. RSA saturates near ``phi = 0.38`` for
monodisperse spheres, so requests above :data:`PHI_RSA_MAX` are refused.
"""
from __future__ import annotations

import numpy as np

from pysim.geometry import closest_params
from pysim.jit import njit
from rodcase.case import HARD_SPHERE_PROTOCOLS

#: highest packing fraction accepted for random sequential addition of spheres
PHI_RSA_MAX = 0.35


def sample_diameters(n: int, distribution: str, mean: float, sigma: float, rng,
                     ratio: float = 1.4, fraction_big: float = 0.5) -> np.ndarray:
    """Particle diameters: ``mono`` (all equal ``mean``), ``lognormal`` with mean
    ``mean`` and standard deviation ``sigma * mean``, or ``bidisperse`` (a fraction
    ``fraction_big`` of the particles, rounded, with diameter ``ratio * mean``)."""
    if distribution == "mono":
        return np.full(n, float(mean))
    if distribution == "bidisperse":
        d = np.full(n, float(mean))
        d[: int(round(fraction_big * n))] = ratio * mean
        return d
    if distribution == "lognormal":
        if sigma <= 0:
            return np.full(n, float(mean))
        # parameters of the underlying normal distribution for the requested moments
        s2 = np.log1p(sigma**2)
        mu = np.log(mean) - 0.5 * s2
        return rng.lognormal(mu, np.sqrt(s2), size=n)
    raise ValueError(f"unknown diameter distribution {distribution!r}; valid: mono, lognormal")


@njit
def _rsa(radius_sorted, box, seed, max_attempts):
    np.random.seed(seed)
    n = radius_sorted.shape[0]
    rmax = radius_sorted[0]
    cell = 2.0 * rmax
    nc = np.empty(3, np.int64)
    for k in range(3):
        nc[k] = max(int(box[k] // cell), 1)
    ncell = nc[0] * nc[1] * nc[2]
    cap = 64
    occupants = -np.ones((ncell, cap), np.int64)
    occ_n = np.zeros(ncell, np.int64)
    x = np.empty((n, 3))
    d = np.empty(3)
    p = np.empty(3)
    ci = np.empty(3, np.int64)
    for i in range(n):
        placed = False
        for _ in range(max_attempts):
            for k in range(3):
                p[k] = np.random.random() * box[k]
                ci[k] = min(int(p[k] / box[k] * nc[k]), nc[k] - 1)
            ok = True
            for dx in range(-1, 2):
                if not ok:
                    break
                for dy in range(-1, 2):
                    if not ok:
                        break
                    for dz in range(-1, 2):
                        cx = (ci[0] + dx) % nc[0]
                        cy = (ci[1] + dy) % nc[1]
                        cz = (ci[2] + dz) % nc[2]
                        c = (cx * nc[1] + cy) * nc[2] + cz
                        for q in range(occ_n[c]):
                            j = occupants[c, q]
                            for k in range(3):
                                d[k] = p[k] - x[j, k]
                                d[k] -= box[k] * np.floor(d[k] / box[k] + 0.5)
                            rs = radius_sorted[i] + radius_sorted[j]
                            if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < rs * rs:
                                ok = False
                                break
                        if not ok:
                            break
            if ok:
                x[i, :] = p
                c = (ci[0] * nc[1] + ci[1]) * nc[2] + ci[2]
                if occ_n[c] == occupants.shape[1]:
                    bigger = -np.ones((ncell, 2 * occupants.shape[1]), np.int64)
                    bigger[:, : occupants.shape[1]] = occupants
                    occupants = bigger
                occupants[c, occ_n[c]] = i
                occ_n[c] += 1
                placed = True
                break
        if not placed:
            return x, i
    return x, n


@njit
def _rsa_rods(radius, half, box, dim, seed, max_attempts):
    """RSA of spherocylinders (radii and half-lengths sorted by decreasing reach)."""
    np.random.seed(seed)
    n = radius.shape[0]
    reach = radius[0] + half[0]
    cell = 2.0 * reach
    nc = np.ones(3, np.int64)
    for k in range(dim):
        nc[k] = max(int(box[k] // cell), 1)
    ncell = nc[0] * nc[1] * nc[2]
    cap = 64
    occupants = -np.ones((ncell, cap), np.int64)
    occ_n = np.zeros(ncell, np.int64)
    x = np.zeros((n, 3))
    u = np.zeros((n, 3))
    p = np.zeros(3)
    a = np.zeros(3)
    ci = np.zeros(3, np.int64)
    lo = np.zeros(3, np.int64)
    hi = np.zeros(3, np.int64)
    for i in range(n):
        placed = False
        for _ in range(max_attempts):
            for k in range(3):
                p[k] = np.random.random() * box[k] if k < dim else 0.0
                a[k] = np.random.normal() if k < dim else 0.0
            an = np.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
            for k in range(3):
                a[k] /= an
                ci[k] = min(int(p[k] / box[k] * nc[k]), nc[k] - 1) if k < dim else 0
                lo[k] = -1 if nc[k] > 2 else 0
                hi[k] = 1 if nc[k] > 2 else nc[k] - 1
                if nc[k] <= 2:
                    ci[k] = 0
            ok = True
            for dx in range(lo[0], hi[0] + 1):
                for dy in range(lo[1], hi[1] + 1):
                    for dz in range(lo[2], hi[2] + 1):
                        if not ok:
                            continue
                        c = (((ci[0] + dx) % nc[0]) * nc[1] + (ci[1] + dy) % nc[1]) * nc[2] \
                            + (ci[2] + dz) % nc[2]
                        for q in range(occ_n[c]):
                            j = occupants[c, q]
                            r0 = p[0] - x[j, 0]
                            r1 = p[1] - x[j, 1]
                            r2 = p[2] - x[j, 2]
                            r0 -= box[0] * np.floor(r0 / box[0] + 0.5)
                            r1 -= box[1] * np.floor(r1 / box[1] + 0.5)
                            if dim == 3:
                                r2 -= box[2] * np.floor(r2 / box[2] + 0.5)
                            s, t = closest_params(r0, r1, r2, a[0], a[1], a[2], half[i],
                                                  u[j, 0], u[j, 1], u[j, 2], half[j])
                            g0 = r0 + s * a[0] - t * u[j, 0]
                            g1 = r1 + s * a[1] - t * u[j, 1]
                            g2 = r2 + s * a[2] - t * u[j, 2]
                            rs = radius[i] + radius[j]
                            if g0 * g0 + g1 * g1 + g2 * g2 < rs * rs:
                                ok = False
                                break
            if ok:
                x[i, :] = p
                u[i, :] = a
                c = (ci[0] * nc[1] + ci[1]) * nc[2] + ci[2]
                if occ_n[c] == occupants.shape[1]:
                    bigger = -np.ones((ncell, 2 * occupants.shape[1]), np.int64)
                    bigger[:, : occupants.shape[1]] = occupants
                    occupants = bigger
                occupants[c, occ_n[c]] = i
                occ_n[c] += 1
                placed = True
                break
        if not placed:
            return x, u, i
    return x, u, n


def random_spherocylinders(radius, length, phi: float, seed: int, dimension: int = 3,
                           max_attempts: int = 1_000_000):
    """Random non-overlapping spherocylinders (isotropic orientations) in a periodic box
    at packing fraction ``phi`` (area fraction in 2-D), by random sequential addition.

    Returns ``(x (N, 3), u (N, 3), radius (N,), length (N,), box (3,))`` in insertion
    order (decreasing reach ``R + L/2``); 2-D states have ``z = 0`` and ``box[2] = 0``.
    Raises ``RuntimeError`` when insertion stalls (lower ``phi``: random insertion of rods
    saturates well below random close packing, the lower the longer the rods).
    """
    from pysim.state import area, volume

    radius = np.asarray(radius, dtype=np.float64)
    length = np.broadcast_to(np.asarray(length, dtype=np.float64), radius.shape)
    order = np.argsort(-(radius + length / 2), kind="stable")
    radius, length = radius[order].copy(), length[order].copy()
    if not 0 < phi < 1:
        raise ValueError(f"packing fraction must be in (0, 1), got {phi}")
    vol = area(radius, length).sum() if dimension == 2 else volume(radius, length).sum()
    side = (vol / phi) ** (1.0 / dimension)
    reach = 2 * (radius[0] + length[0] / 2)
    if side < 2.0 * reach:
        raise ValueError(f"box side {side:.3g} is below twice the longest particle ({reach:.3g}); "
                         "use more particles")
    box = np.array([side, side, side if dimension == 3 else 0.0])
    boxc = box.copy()
    if dimension == 2:
        boxc[2] = 1.0
    x, u, placed = _rsa_rods(radius, length / 2, boxc, dimension, int(seed) % (2**32),
                             int(max_attempts))
    if placed < len(radius):
        raise RuntimeError(f"random insertion placed only {placed} of {len(radius)} "
                           f"spherocylinders at phi = {phi}; lower the packing fraction")
    return x, u, radius, length, box


@njit
def _rsa_rods_walled(radius, half, shape, size, height, dim, seed, max_attempts):
    """RSA of spherocylinders inside a container standing on the floor (height 0 along
    the vertical axis ``v = dim - 1``) up to ``height``: ``shape`` 0 a cylinder of radius
    ``size`` with its axis at ``x = y = 0`` (3-D), 1 a box ``0 < x (, y) < size``. Every
    spine end lies at least ``R`` inside the walls, above the floor and below the top.
    Brute-force overlap tests against the grains of neighbouring height bands."""
    np.random.seed(seed)
    n = radius.shape[0]
    v = dim - 1
    reach = radius[0] + half[0]
    band = 2.0 * reach
    nb = max(int(height // band), 1)
    members = -np.ones((nb, 64), np.int64)
    count = np.zeros(nb, np.int64)
    x = np.zeros((n, 3))
    u = np.zeros((n, 3))
    p = np.zeros(3)
    a = np.zeros(3)
    e = np.zeros(3)
    for i in range(n):
        placed = False
        for _ in range(max_attempts):
            if shape == 0:
                rho = (size - radius[i]) * np.sqrt(np.random.random())
                th = 2.0 * np.pi * np.random.random()
                p[0] = rho * np.cos(th)
                p[1] = rho * np.sin(th)
            else:
                for k in range(v):
                    p[k] = radius[i] + np.random.random() * (size - 2.0 * radius[i])
            p[v] = radius[i] + np.random.random() * (height - 2.0 * radius[i])
            for k in range(3):
                a[k] = np.random.normal() if k < dim else 0.0
            an = np.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
            ok = True
            for k in range(3):
                a[k] /= an
            for sg in (-1.0, 1.0):
                for k in range(3):
                    e[k] = p[k] + sg * half[i] * a[k]
                if e[v] < radius[i] or e[v] > height - radius[i]:
                    ok = False
                if shape == 0 and e[0] * e[0] + e[1] * e[1] > (size - radius[i]) ** 2:
                    ok = False
                for k in range(v if shape == 1 else 0):
                    if e[k] < radius[i] or e[k] > size - radius[i]:
                        ok = False
            if not ok:
                continue
            b = min(int(p[v] / band), nb - 1)
            for bb in range(max(b - 1, 0), min(b + 2, nb)):
                if not ok:
                    break
                for q in range(count[bb]):
                    j = members[bb, q]
                    r0 = p[0] - x[j, 0]
                    r1 = p[1] - x[j, 1]
                    r2 = p[2] - x[j, 2]
                    s, tt = closest_params(r0, r1, r2, a[0], a[1], a[2], half[i],
                                           u[j, 0], u[j, 1], u[j, 2], half[j])
                    g0 = r0 + s * a[0] - tt * u[j, 0]
                    g1 = r1 + s * a[1] - tt * u[j, 1]
                    g2 = r2 + s * a[2] - tt * u[j, 2]
                    rs = radius[i] + radius[j]
                    if g0 * g0 + g1 * g1 + g2 * g2 < rs * rs:
                        ok = False
                        break
            if ok:
                x[i, :] = p
                u[i, :] = a
                if count[b] == members.shape[1]:
                    bigger = -np.ones((nb, 2 * members.shape[1]), np.int64)
                    bigger[:, : members.shape[1]] = members
                    members = bigger
                members[b, count[b]] = i
                count[b] += 1
                placed = True
                break
        if not placed:
            return x, u, i
    return x, u, n


def random_spherocylinders_in_cylinder(radius, length, phi: float, diameter_c: float, seed: int,
                                       max_attempts: int = 1_000_000):
    """Random non-overlapping spherocylinders (isotropic orientations) inside a vertical
    cylinder of inner diameter ``diameter_c`` (axis ``x = y = 0``) above a floor at
    ``z = 0``, filled to the height ``H`` at which the grains occupy a fraction ``phi`` of
    the cylinder: ``H = sum V_i / (phi pi D_c^2 / 4)``. Random sequential addition.

    Returns ``(x, u, radius, length, height)`` in insertion order (decreasing reach).
    Raises ``RuntimeError`` when insertion stalls (lower ``phi``).
    """
    from pysim.state import volume

    radius = np.asarray(radius, dtype=np.float64)
    length = np.broadcast_to(np.asarray(length, dtype=np.float64), radius.shape)
    order = np.argsort(-(radius + length / 2), kind="stable")
    radius, length = radius[order].copy(), length[order].copy()
    if not 0 < phi < 1:
        raise ValueError(f"packing fraction must be in (0, 1), got {phi}")
    rc = 0.5 * float(diameter_c)
    if not rc > radius[0] + length[0] / 2:
        raise ValueError(f"cylinder diameter {diameter_c:.4g} is too narrow for grains of length "
                         f"{2 * radius[0] + length[0]:.4g}")
    height = float(volume(radius, length).sum() / (phi * np.pi * rc * rc))
    height = max(height, 2.0 * (radius[0] + length[0] / 2))
    x, u, placed = _rsa_rods_walled(radius, length / 2, 0, rc, height, 3, int(seed) % (2**32),
                                    int(max_attempts))
    if placed < len(radius):
        raise RuntimeError(f"random insertion placed only {placed} of {len(radius)} "
                           f"spherocylinders in the cylinder at phi = {phi}; lower phi_init")
    return x, u, radius, length, height


def random_spherocylinders_in_box(radius, length, phi: float, width: float, seed: int,
                                  dimension: int = 3, max_attempts: int = 1_000_000):
    """Random non-overlapping spherocylinders (isotropic orientations) in a box
    ``0 < x (, y) < width`` above a floor at height 0 along the last axis (``z``; ``y`` in
    2-D), filled to the height ``H`` at which the grains occupy a fraction ``phi`` of the
    box: ``H = sum V_i / (phi W^(d-1))``. Random sequential addition.

    Returns ``(x, u, radius, length, height)`` in insertion order (decreasing reach).
    """
    from pysim.state import area, volume

    radius = np.asarray(radius, dtype=np.float64)
    length = np.broadcast_to(np.asarray(length, dtype=np.float64), radius.shape)
    order = np.argsort(-(radius + length / 2), kind="stable")
    radius, length = radius[order].copy(), length[order].copy()
    if not 0 < phi < 1:
        raise ValueError(f"packing fraction must be in (0, 1), got {phi}")
    if not width > 2 * radius[0] + length[0]:
        raise ValueError(f"box width {width:.4g} is too narrow for grains of length "
                         f"{2 * radius[0] + length[0]:.4g}")
    measure = area(radius, length) if dimension == 2 else volume(radius, length)
    height = float(measure.sum() / (phi * width ** (dimension - 1)))
    height = max(height, 2.0 * (radius[0] + length[0] / 2))
    x, u, placed = _rsa_rods_walled(radius, length / 2, 1, float(width), height, dimension,
                                    int(seed) % (2**32), int(max_attempts))
    if placed < len(radius):
        raise RuntimeError(f"random insertion placed only {placed} of {len(radius)} "
                           f"spherocylinders in the box at phi = {phi}; lower phi_init")
    return x, u, radius, length, height


def random_spheres(diameters: np.ndarray, phi: float, seed: int, max_attempts: int = 1_000_000):
    """Place spheres with the given diameters without overlap in a periodic cube at
    packing fraction ``phi``.

    Returns ``(x (N, 3), diameters (N,), box (3,))``; the box is ``[0, L)^3`` with
    ``L = (sum V_i / phi)^(1/3)``. Particles are returned in order of decreasing
    size (the insertion order). Raises ``ValueError`` when ``phi`` exceeds
    :data:`PHI_RSA_MAX` or insertion fails.
    """
    diameters = np.sort(np.asarray(diameters, dtype=np.float64))[::-1].copy()
    if not 0 < phi <= PHI_RSA_MAX:
        raise ValueError(
            f"initial packing fraction phi_init = {phi} cannot be reached by random "
            f"insertion; use 0 < phi_init <= {PHI_RSA_MAX} and compress")
    vol = np.sum(np.pi / 6.0 * diameters**3)
    side = (vol / phi) ** (1.0 / 3.0)
    if side < 2.0 * diameters[0]:
        raise ValueError(
            f"box side {side:.3g} is below two largest diameters ({diameters[0]:.3g}); "
            "use more particles")
    box = np.full(3, side)
    x, placed = _rsa(diameters / 2.0, box, int(seed) % (2**32), int(max_attempts))
    if placed < len(diameters):
        raise RuntimeError(
            f"random insertion placed only {placed} of {len(diameters)} spheres at "
            f"phi = {phi}; lower phi_init")
    return x, diameters, box


#: starts of this many particles or more are written sorted by cell
#: (:func:`pysim.neighbors.spatial_order`); smaller ones keep the insertion order, so
#: the studies' starts (at most 6000 particles) and their results stay as they were.
#: pysim's contact pass reads each pair's second particle, which sorting keeps close in
#: memory: a large gain once the particles leave the cache, little below
#: (docs/performance.md)
SORT_MIN = 20_000


def _by_cell(lo, box, x, *arrays):
    """``x`` and ``arrays`` (per particle) in :func:`pysim.neighbors.spatial_order` of the
    box ``[lo, lo + box)`` when there are :data:`SORT_MIN` particles or more."""
    if len(x) < SORT_MIN:
        return (x, *arrays)
    from pysim.neighbors import spatial_order

    order = spatial_order(np.asarray(x) - np.asarray(lo), np.asarray(box))
    return tuple(a[order] for a in (x, *arrays))


def write_initial(case: dict, path) -> None:
    """Write the random non-overlapping start of a case as a LAMMPS data file.

    Diameters are drawn with ``numpy.random.default_rng(seed)``, positions (and axes) by
    RSA seeded with the same ``seed``, at ``protocol.phi_init``. 3-D spheres go to an
    ``atom_style sphere`` file, everything else (rods, 2-D) to an ``atom_style
    ellipsoid`` file (:func:`pysim.io.write_rod_data`). Particles are in insertion order
    (largest first), or sorted by cell from :data:`SORT_MIN` particles on.
    """
    from pysim.io import write_rod_data, write_sphere_data

    p = case["particles"]
    seed = int(case["seed"])
    rng = np.random.default_rng(seed)
    dd = p["diameter"]
    d = sample_diameters(p["n"], dd.get("distribution", "mono"), dd["mean"], dd.get("sigma", 0.0),
                         rng, dd.get("ratio", 1.4), dd.get("fraction_big", 0.5))
    if case["protocol"]["name"] in HARD_SPHERE_PROTOCOLS:
        _write_poisson(case, d, rng, path)
        return
    phi = case["protocol"]["phi_init"]
    dim = p.get("dimension", 3)
    alpha = p.get("aspect_ratio", 0.0)
    title = f"rodpack random start, seed {seed}, phi {phi}"
    if "feed" in case["protocol"]:
        w = case["container"]["width"]
        x, u, margin, top = feed_queue(d / 2.0, alpha * d, w, case["protocol"]["feed"]["height"])
        lo = np.array([-margin, -margin, -0.5])
        hi = np.array([w + margin, top + margin, 0.5])
        write_rod_data(path, x, u, d / 2.0, alpha * d, hi - lo, p.get("density", 1.0),
                       dimension=dim, title=title + f", fed into a box of width {w:g}", box_lo=lo)
        return
    if case.get("container", {}).get("shape") == "box":
        w = case["container"]["width"]
        x, u, r, length, height = random_spherocylinders_in_box(d / 2.0, alpha * d, phi, w, seed,
                                                                 dimension=dim)
        # random velocities of rms speed v_init (isotropic in the d dimensions)
        v = rng.normal(size=(len(r), 3)) * case["protocol"].get("v_init", 0.0) / np.sqrt(dim)
        if dim == 2:
            v[:, 2] = 0.0
        margin = float(np.max(2 * r + length))
        lo = np.array([-margin, -margin, -margin])
        hi = np.array([w + margin, w + margin, height + margin])
        if dim == 2:
            lo[1], hi[1] = -margin, height + margin
            lo[2], hi[2] = -0.5, 0.5
        x, u, r, length, v = _by_cell(lo, hi - lo, x, u, r, length, v)
        write_rod_data(path, x, u, r, length, hi - lo, p.get("density", 1.0), dimension=dim,
                       title=title + f" in a box of width {w:g}", box_lo=lo, v=v)
        return
    if "container" in case:
        dc = case["container"]["diameter"]
        x, u, r, length, height = random_spherocylinders_in_cylinder(d / 2.0, alpha * d, phi, dc,
                                                                     seed)
        pr = case["protocol"]
        amp = case["gravity"] * pr["intensity"] / (2 * np.pi * pr["frequency"]) ** 2
        lo, box = container_box(dc, height, float(np.max(2 * r + length)), amp)
        x, u, r, length = _by_cell(lo, box, x, u, r, length)
        write_rod_data(path, x, u, r, length, box, p.get("density", 1.0), title=title + " in a "
                       f"cylinder of diameter {dc:g}", box_lo=lo)
        return
    if dim == 3 and alpha == 0:
        x, d, box = random_spheres(d, phi, seed)
        x, d = _by_cell(np.zeros(3), box, x, d)
        write_sphere_data(path, x, d, box, p.get("density", 1.0), title=title)
        return
    x, u, r, length, box = random_spherocylinders(d / 2.0, alpha * d, phi, seed, dimension=dim)
    x, u, r, length = _by_cell(np.zeros(3), box, x, u, r, length)
    write_rod_data(path, x, u, r, length, box, p.get("density", 1.0), dimension=dim, title=title)


def _write_poisson(case: dict, d, rng, path) -> None:
    """The start of a hard-sphere case (:mod:`pysim.hard.start`): the diameters rescaled
    to mean 1 (the paper's normalisation), at Poisson points (overlapping) in the cube
    where they fill ``protocol.phi_nominal``."""
    from pysim.hard.start import box_side, poisson
    from pysim.io import write_sphere_data

    d = d / np.mean(d)
    phi = case["protocol"]["phi_nominal"]
    side = box_side(d, phi)
    x = poisson(len(d), side, rng)
    write_sphere_data(path, x, d, np.full(3, side), case["particles"].get("density", 1.0),
                      title=f"rodpack Poisson start, seed {case['seed']}, nominal phi {phi}")


def feed_queue(radius, length, width: float, height: float):
    """The grains of a fed 2-D deposit (:mod:`pysim.protocols.deposit`) before they
    enter: in feed order, lying flat in rows above the entry line ``y = height`` of a
    box of ``width``, clear of each other (gaps of 0.1 of the largest diameter). Only
    their sizes and order matter: each grain's entry position, orientation and velocity
    are drawn when it enters. Returns ``(x, axis, margin, top)``: positions (N, 3),
    spine directions, the margin of one grain length the data file's box keeps around
    the container, and the height of the queue's top."""
    radius = np.asarray(radius, dtype=np.float64)
    length = np.broadcast_to(np.asarray(length, dtype=np.float64), radius.shape)
    gap = 0.2 * radius.max()
    longest = float(np.max(2 * radius + length))
    pitch_x, pitch_y = longest + gap, 2.0 * radius.max() + gap
    per_row = max(int(width // pitch_x), 1)
    k = np.arange(len(radius))
    x = np.zeros((len(radius), 3))
    x[:, 0] = (k % per_row + 0.5) * pitch_x
    x[:, 1] = height + longest + (k // per_row + 0.5) * pitch_y
    axis = np.tile([1.0, 0.0, 0.0], (len(radius), 1))
    return x, axis, longest, float(x[:, 1].max() + pitch_y)


def container_box(diameter_c: float, height: float, longest: float,
                  depth: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``(box_lo, box)`` around a cylinder of diameter ``diameter_c`` on its axis
    ``x = y = 0``: the square cross-section plus a margin of one ``longest`` grain, from
    ``depth`` plus a grain below the base (which oscillates down to ``-depth``) to a grain
    above the initial fill ``height``."""
    half = 0.5 * diameter_c + longest
    lo = np.array([-half, -half, -(depth + longest)])
    hi = np.array([half, half, height + longest])
    return lo, hi - lo
