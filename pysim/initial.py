"""Random non-overlapping initial configurations (made once, shared by all engines).

Random sequential addition (RSA) of spheres into a periodic box: each sphere is
tried at uniformly random positions until it overlaps none of those already
placed. Spheres are placed largest first. RSA saturates near ``phi = 0.38`` for
monodisperse spheres, so requests above :data:`PHI_RSA_MAX` are refused.
"""
from __future__ import annotations

import numpy as np

from pysim.jit import njit

#: highest packing fraction accepted for random sequential addition of spheres
PHI_RSA_MAX = 0.35


def sample_diameters(n: int, distribution: str, mean: float, sigma: float, rng) -> np.ndarray:
    """Particle diameters: ``mono`` (all equal ``mean``) or ``lognormal`` with mean
    ``mean`` and standard deviation ``sigma * mean`` (length units)."""
    if distribution == "mono":
        return np.full(n, float(mean))
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


def write_initial(case: dict, path) -> None:
    """Write the random non-overlapping start of a case as a LAMMPS data file.

    Diameters are drawn with ``numpy.random.default_rng(seed)``, positions by RSA
    seeded with the same ``seed``, at ``protocol.phi_init``.
    """
    from pysim.io import write_sphere_data

    p = case["particles"]
    seed = int(case["seed"])
    rng = np.random.default_rng(seed)
    d = sample_diameters(p["n"], p["diameter"].get("distribution", "mono"),
                         p["diameter"]["mean"], p["diameter"].get("sigma", 0.0), rng)
    phi = case["protocol"]["phi_init"]
    x, d, box = random_spheres(d, phi, seed)
    write_sphere_data(path, x, d, box, p.get("density", 1.0),
                      title=f"rodpack random start, seed {seed}, phi {phi}")
