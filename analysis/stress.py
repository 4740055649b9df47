"""Stress from contact forces (science.md section 5).

Per particle ``sigma^i_ab = sum_c l^c_a F^c_b`` with ``l^c`` from the centre of ``i``
to the contact point and ``F^c`` the force on ``i`` (force x length). Over a volume
``V`` (2-D: an area) with particle-centre weighting,
``sigma_ab = (1/V) sum_i w_i sigma^i_ab`` with ``w_i = 1`` when the centre of ``i`` lies
in ``V`` (tension positive). The pressure is ``p = -tr(sigma)/d``.

* the whole box: :func:`stress_tensor`, :func:`pressure`;
* horizontal slabs (profiles versus depth): :class:`StressProfile`;
* square (2-D) or cubic (3-D) elements: :class:`StressField`;
* principal stresses and the direction of the major (most compressive) one:
  :func:`principal_stresses`, :func:`major_axis_angle`, per grain
  :func:`particle_major_angles`, and how vertical those directions are:
  :func:`major_axis_order`;
* the trace of the mean stress in a grid of elements: :func:`element_trace`;
* stresses on a wall from the wall rows of a contact table: :class:`WallStress`.

Wall rows (``j <= 0``, :mod:`analysis.walls`) contribute their branch
vector and force to the grain ``i`` only.
"""
from __future__ import annotations

import numpy as np

from analysis.base import Observable
from analysis.frame import Contacts, Frame


def _branch(frame: Frame, rows: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Branch vectors from particle centres to contact points (minimum image)."""
    return frame.minimum_image(point - frame.x[rows])


def particle_stress(frame: Frame, contacts: Contacts) -> np.ndarray:
    """``sigma^i`` (N, 3, 3): ``sum_c l^c_a F^c_b`` over the contacts of each particle
    (force units x length). Wall rows act on their grain ``i`` only."""
    a = frame.index_of(contacts.i)
    wall = contacts.j <= 0
    out = np.zeros((frame.n, 3, 3))
    la = _branch(frame, a, contacts.point)
    np.add.at(out, a, la[:, :, None] * contacts.force[:, None, :])
    pp = ~wall
    b = frame.index_of(contacts.j[pp])
    lb = _branch(frame, b, contacts.point[pp])
    np.add.at(out, b, lb[:, :, None] * (-contacts.force[pp])[:, None, :])
    return out


def stress_tensor(frame: Frame, contacts: Contacts) -> np.ndarray:
    """Box-averaged contact stress ``sigma_ab = (1/V) sum_i sigma^i_ab`` (3, 3); ``V`` is
    the box volume (2-D frames: the box area, :attr:`Frame.measure`)."""
    return particle_stress(frame, contacts).sum(axis=0) / frame.measure


def pressure(frame: Frame, contacts: Contacts, dim: int | None = None) -> float:
    """Contact pressure ``p = -tr(sigma)/d`` (force / length^(d-1)); ``dim`` defaults to
    the frame's dimension."""
    dim = frame.dim if dim is None else dim
    s = stress_tensor(frame, contacts)
    return float(-np.trace(s[:dim, :dim]) / dim)


def principal_stresses(sigma, dim: int = 3):
    """Principal values (..., d) ascending (the first is the most compressive, since
    tension is positive) and directions (..., d, d) (columns) of stress tensors
    ``sigma`` (..., 3, 3) restricted to the first ``dim`` axes."""
    s = np.asarray(sigma, dtype=np.float64)[..., :dim, :dim]
    s = 0.5 * (s + np.swapaxes(s, -1, -2))
    return np.linalg.eigh(s)


def major_axis_angle(sigma, dim: int = 3, vertical: int | None = None) -> np.ndarray:
    """Angle between the major (most compressive) principal axis and the horizontal
    (radians): 2-D signed in ``(-pi/2, pi/2]`` (counter-clockwise from +x), 3-D in
    ``[0, pi/2]`` (elevation above the horizontal plane)."""
    vertical = dim - 1 if vertical is None else vertical
    _, vec = principal_stresses(sigma, dim)
    v = vec[..., :, 0]
    if dim == 2:
        ang = np.arctan2(v[..., 1], v[..., 0])
        ang = np.where(ang <= -np.pi / 2, ang + np.pi, ang)
        return np.where(ang > np.pi / 2, ang - np.pi, ang)
    return np.arcsin(np.clip(np.abs(v[..., vertical]), 0.0, 1.0))


def major_axis_order(angles, dim: int = 3, weights=None) -> float:
    """How vertical the major principal axes are, from their angles to the horizontal
    ``angles`` (radians, :func:`major_axis_angle`; NaN entries are left out), optionally
    weighted: the mean of ``-cos 2 theta`` in 2-D and of ``P2(sin theta) = (3 sin^2
    theta - 1) / 2`` in 3-D. Both are 1 when every major axis is vertical, 0 for
    directions spread uniformly (over the angle in 2-D, over the sphere in 3-D) and -1
    (2-D) or -1/2 (3-D) when all are horizontal. NaN without a finite angle."""
    a = np.asarray(angles, dtype=np.float64).ravel()
    w = np.ones_like(a) if weights is None else np.asarray(weights, np.float64).ravel()
    ok = np.isfinite(a) & (w > 0)
    if not ok.any():
        return float("nan")
    f = -np.cos(2.0 * a[ok]) if dim == 2 else 1.5 * np.sin(a[ok]) ** 2 - 0.5
    return float(np.average(f, weights=w[ok]))


def coarse_grain(frame: Frame, sigma_i: np.ndarray, edges: list) -> tuple[np.ndarray, np.ndarray]:
    """Particle-centre coarse graining: ``(sigma (cells..., 3, 3), count (cells...))``.

    ``edges`` lists, for each of the first ``len(edges)`` axes, the bin edges (``None``:
    the whole box along that axis); a particle counts in the cell holding its centre
    (periodic axes: wrapped into the box). Cell measure = product of the edge widths
    times the box along the remaining axes of the frame's dimension.
    """
    d = frame.dim
    x = frame.x - frame.box_lo
    period = np.where(frame.periodic, frame.box, 1.0)  # no modulo by a flat 2-D box's 0
    x = np.where(frame.periodic, np.mod(x, period), x) + frame.box_lo
    idx, shape, widths = [], [], []
    for k in range(d):
        e = edges[k] if k < len(edges) else None
        if e is None:
            e = np.array([frame.box_lo[k], frame.box_lo[k] + frame.box[k]])
        e = np.asarray(e, dtype=np.float64)
        if e.ndim != 1 or len(e) < 2 or np.any(np.diff(e) <= 0):
            raise ValueError(f"edges along axis {k} must be increasing, got {e[:6]}")
        i = np.searchsorted(e, x[:, k], side="right") - 1
        i[x[:, k] == e[-1]] = len(e) - 2
        idx.append(i)
        shape.append(len(e) - 1)
        widths.append(np.diff(e))
    idx = np.array(idx)
    inside = np.all((idx >= 0) & (idx < np.array(shape)[:, None]), axis=0)
    flat = np.ravel_multi_index(tuple(idx[:, inside]), tuple(shape))
    ncell = int(np.prod(shape))
    total = np.zeros((ncell, 3, 3))
    np.add.at(total, flat, sigma_i[inside])
    count = np.bincount(flat, minlength=ncell).reshape(shape)
    vol = widths[0]
    for w in widths[1:]:
        vol = np.multiply.outer(vol, w)
    return total.reshape(*shape, 3, 3) / vol[..., None, None], count


def _column_stresses(frame: Frame, contacts: Contacts, edges, lo: float, hi: float,
                     columns: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean stress in elements: rows between consecutive ``edges`` along the vertical
    axis, ``columns`` equal elements per horizontal axis of the container ``lo < x (, y)
    < hi`` (particle-centre weighting). Returns ``(sigma (rows, columns^(d-1), 3, 3),
    count (rows, columns^(d-1)))``."""
    if not hi > lo:
        raise ValueError(f"the container must have hi > lo, got lo = {lo}, hi = {hi}")
    d, v = frame.dim, frame.vertical
    spec = [None] * d
    spec[v] = np.asarray(edges, dtype=np.float64)
    for k in range(d):
        if k != v:
            spec[k] = np.linspace(lo, hi, columns + 1)
    sig, cnt = coarse_grain(frame, particle_stress(frame, contacts), spec)
    rows = len(spec[v]) - 1
    return (np.moveaxis(sig, v, 0).reshape(rows, -1, 3, 3),
            np.moveaxis(cnt, v, 0).reshape(rows, -1))


def slab_stress_errors(frame: Frame, contacts: Contacts, edges, lo: float, hi: float,
                       columns: int) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors of the vertical and mean horizontal normal stress in horizontal
    slabs (``edges`` along the vertical axis) from their spread over ``columns`` equal
    columns per horizontal axis of the container ``lo < x (, y) < hi``: the sample
    standard deviation ``s`` of the column stresses over the square root of their
    number, ``s / sqrt(n)`` (``n = columns^(d-1)``; the slab stress is the columns'
    mean when every grain centre lies in the container). Returns
    ``(sigma_vv_err, sigma_hh_err)`` (K,), stress units. Neighbouring grains carry
    correlated stresses (force chains); columns much wider than a chain's correlation
    length give honest errors, narrower ones underestimate them."""
    if columns < 2:
        raise ValueError(f"columns must be at least 2 to measure a spread, got {columns}")
    d, v = frame.dim, frame.vertical
    sig, _ = _column_stresses(frame, contacts, edges, lo, hi, columns)
    n = sig.shape[1]
    s_vv = sig[:, :, v, v]
    s_hh = np.mean([sig[:, :, k, k] for k in range(d) if k != v], axis=0)
    return s_vv.std(axis=1, ddof=1) / np.sqrt(n), s_hh.std(axis=1, ddof=1) / np.sqrt(n)


def element_trace(frame: Frame, contacts: Contacts, edges, lo: float, hi: float,
                  columns: int) -> tuple[np.ndarray, np.ndarray]:
    """Trace of the mean stress tensor, compressive positive, ``-tr sigma`` (force /
    length^(d-2)), in representative volume elements (Hidalgo et al., Eq. 4 and Fig. 6:
    ``sigma_ab = (1/A) sum_i w_i sigma^i_ab`` with ``w_i = 1`` for a centre inside the
    element): rows between consecutive ``edges`` along the vertical axis, ``columns``
    equal elements per horizontal axis of the container ``lo < x (, y) < hi``. Returns
    ``(trace (rows, columns^(d-1)), count (rows, columns^(d-1)))``, ``count`` the grain
    centres in each element."""
    if columns < 1:
        raise ValueError(f"columns must be at least 1, got {columns}")
    d = frame.dim
    sig, cnt = _column_stresses(frame, contacts, edges, lo, hi, columns)
    return -np.trace(sig[..., :d, :d], axis1=-2, axis2=-1), cnt


def particle_major_angles(frame: Frame, contacts: Contacts) -> np.ndarray:
    """Angle to the horizontal (radians, :func:`major_axis_angle`) of the major (most
    compressive) principal axis of each grain's own stress ``sigma^i_ab = sum_c l^c_a
    F^c_b`` (Hidalgo et al., Eq. 3 and Fig. 5), for the grains with a nonzero stress;
    grains without contacts have no direction and are left out."""
    d = frame.dim
    sig = particle_stress(frame, contacts)
    loaded = np.any(sig[:, :d, :d] != 0.0, axis=(1, 2))
    return major_axis_angle(sig[loaded], d, frame.vertical)


def _pressure_of(sigma, dim):
    return -np.trace(sigma[..., :dim, :dim], axis1=-2, axis2=-1) / dim


class StressProfile(Observable):
    """Stress in horizontal slabs versus depth.

    Parameters: slab ``thickness`` (tiling the box from its bottom) or ``edges`` along
    the vertical axis; ``top`` the reference height of depth 0 (default the top surface
    of the grains, :func:`analysis.packing.surface_height`); ``area`` the horizontal
    cross-section the grains fill (2-D: a width; default the box's; give the container's
    when the box is wider than it, so that a slab's measure is ``area * thickness``).
    Results: ``edges``,
    ``centers``, ``depth`` (``top - centre``), ``sigma`` (K, 3, 3), ``pressure`` (K,),
    ``sigma_vv`` (K,) vertical normal stress, ``sigma_hh`` (K,) mean horizontal normal
    stress, ``k_ratio`` (K,) ``sigma_hh / sigma_vv`` (Janssen's ``K``), ``count`` (K,)
    particles per slab. Stresses are tension-positive: compressive profiles are negative.
    """

    _results = ("edges", "centers", "depth", "sigma", "pressure", "sigma_vv", "sigma_hh",
                "k_ratio", "count")

    def __init__(self, thickness: float | None = None, edges=None, top: float | None = None,
                 area: float | None = None):
        if (thickness is None) == (edges is None):
            raise ValueError("give exactly one of thickness or edges")
        if thickness is not None and not thickness > 0:
            raise ValueError(f"thickness must be > 0, got {thickness}")
        if area is not None and not area > 0:
            raise ValueError(f"area must be > 0, got {area}")
        self.thickness, self.slab_edges, self.top, self.area = thickness, edges, top, area

    def compute(self, frame: Frame, contacts: Contacts):
        from analysis.packing import horizontal_area, surface_height

        v, d = frame.vertical, frame.dim
        if self.slab_edges is not None:
            edges = np.asarray(self.slab_edges, dtype=np.float64)
        else:
            k = max(int(np.floor(frame.box[v] / self.thickness + 1e-9)), 1)
            edges = frame.box_lo[v] + self.thickness * np.arange(k + 1)
        spec = [None] * d
        spec[v] = edges
        sig, cnt = coarse_grain(frame, particle_stress(frame, contacts), spec)
        sig = sig.reshape(len(edges) - 1, 3, 3)
        if self.area is not None:  # coarse_grain divided by the box's cross-section
            sig = sig * (horizontal_area(frame) / self.area)
        cnt = cnt.reshape(-1)
        horiz = [k for k in range(d) if k != v]
        s_vv = sig[:, v, v]
        s_hh = np.mean([sig[:, k, k] for k in horiz], axis=0)
        top = surface_height(frame) if self.top is None else float(self.top)
        centers = 0.5 * (edges[1:] + edges[:-1])
        with np.errstate(invalid="ignore", divide="ignore"):
            kr = s_hh / s_vv
        self._set(edges=edges, centers=centers, depth=top - centers, sigma=sig,
                  pressure=_pressure_of(sig, d), sigma_vv=s_vv, sigma_hh=s_hh, k_ratio=kr,
                  count=cnt)
        return self


class StressField(Observable):
    """Stress coarse-grained in square (2-D) or cubic (3-D) elements of side ``element``
    tiling the box (the number per axis is ``round(box / element)``, so elements tile
    exactly and their side is adjusted slightly).

    Results: ``edges`` (list per axis), ``sigma`` (cells..., 3, 3), ``pressure``,
    ``count`` (particles per element), ``principal`` (cells..., d) values ascending
    (most compressive first), ``major_angle`` (:func:`major_axis_angle`, radians;
    nan in empty elements), ``angle_hist`` and ``angle_edges``: the distribution of the
    major axis angle over non-empty elements (density), and ``major_order``
    (:func:`major_axis_order` over the elements holding at least ``min_count`` particle
    centres: 1 all major axes vertical, 0 spread uniformly).
    """

    _results = ("edges", "sigma", "pressure", "count", "principal", "major_angle",
                "angle_hist", "angle_edges", "major_order")

    def __init__(self, element: float, angle_bins: int = 18, min_count: int = 1):
        if not element > 0:
            raise ValueError(f"element must be > 0, got {element}")
        self.element, self.angle_bins = float(element), int(angle_bins)
        self.min_count = int(min_count)

    def compute(self, frame: Frame, contacts: Contacts):
        d = frame.dim
        edges = []
        for k in range(d):
            m = max(int(round(frame.box[k] / self.element)), 1)
            edges.append(frame.box_lo[k] + frame.box[k] * np.arange(m + 1) / m)
        sig, cnt = coarse_grain(frame, particle_stress(frame, contacts), edges)
        vals, _ = principal_stresses(sig, d)
        ang = major_axis_angle(sig, d, frame.vertical)
        ang = np.where(cnt > 0, ang, np.nan)
        rng = (-np.pi / 2, np.pi / 2) if d == 2 else (0.0, np.pi / 2)
        ok = np.isfinite(ang)
        hist, he = np.histogram(ang[ok], bins=self.angle_bins, range=rng,
                                density=bool(ok.any()))
        order = major_axis_order(np.where(cnt >= self.min_count, ang, np.nan), d)
        self._set(edges=edges, sigma=sig, pressure=_pressure_of(sig, d), count=cnt,
                  principal=vals, major_angle=ang, angle_hist=hist, angle_edges=he,
                  major_order=order)
        return self


class WallStress(Observable):
    """Forces and stresses on one wall from the wall rows of a contact table.

    ``wall`` a :class:`analysis.walls.PlaneWall` or :class:`analysis.walls.CylinderWall`
    (its ``wall_id`` selects the rows). Totals: ``force`` (3,) on the wall
    (``-sum F``), ``normal_force`` (compressive positive: ``-sum F . n`` with ``n`` the
    grain-to-wall normal), and, with ``area``, ``sigma_n`` and ``tau`` (the force on the
    wall along the vertical axis, per area). Profile (with ``edges`` along the vertical
    axis, rows binned by contact point): ``centers``, ``sigma_n_profile``,
    ``tau_profile``, ``count`` - per band, force over ``perimeter x band height`` where
    the perimeter is ``2 pi R_c`` for a cylinder and ``width`` for a plane (default: the
    box edge along the horizontal axis parallel to the plane; 1 in 2-D).
    """

    _results = ("force", "normal_force", "sigma_n", "tau", "centers", "sigma_n_profile",
                "tau_profile", "count", "n_contacts")

    def __init__(self, wall, edges=None, area: float | None = None, width: float | None = None):
        self.wall, self.area, self.width = wall, area, width
        self.edges = None if edges is None else np.asarray(edges, dtype=np.float64)

    def _perimeter(self, frame: Frame) -> float:
        from analysis.walls import CylinderWall

        if isinstance(self.wall, CylinderWall):
            return 2.0 * np.pi * self.wall.radius
        if self.width is not None:
            return float(self.width)
        if frame.dim == 2:
            return 1.0
        m = np.abs(np.asarray(self.wall.normal, dtype=np.float64))
        v = frame.vertical
        horiz = [k for k in range(3) if k != v]
        if m[v] > 1e-12 or np.count_nonzero(m[horiz] > 1e-12) != 1:
            raise ValueError("give width= for a plane wall that is not a vertical coordinate "
                             "plane")
        other = [k for k in horiz if m[k] <= 1e-12][0]
        return float(frame.box[other])

    def compute(self, frame: Frame, contacts: Contacts):
        sel = contacts.j == self.wall.wall_id
        c = contacts.subset(sel)
        f_wall = -c.force
        fn = np.sum(f_wall * c.normal, axis=1)
        v = frame.vertical
        total = f_wall.sum(axis=0)
        res = dict(force=total, normal_force=float(fn.sum()), n_contacts=int(c.n))
        if self.area is not None:
            res.update(sigma_n=float(fn.sum()) / self.area, tau=float(total[v]) / self.area)
        else:
            res.update(sigma_n=np.nan, tau=np.nan)
        if self.edges is not None:
            e = self.edges
            h = c.point[:, v]
            cnt, _ = np.histogram(h, bins=e)
            sn, _ = np.histogram(h, bins=e, weights=fn)
            tv, _ = np.histogram(h, bins=e, weights=f_wall[:, v])
            band = self._perimeter(frame) * np.diff(e)
            res.update(centers=0.5 * (e[1:] + e[:-1]), sigma_n_profile=sn / band,
                       tau_profile=tv / band, count=cnt)
        else:
            res.update(centers=np.zeros(0), sigma_n_profile=np.zeros(0), tau_profile=np.zeros(0),
                       count=np.zeros(0, int))
        self._set(**res)
        return self
