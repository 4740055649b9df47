"""Packing fraction: global, in horizontal slabs (density profile), per layer, and of the
filled part of a container (science.md section 5).

* global: ``phi = sum_i V_i / V_box`` (2-D: areas over the box area);
* slab ``[h_k, h_k+1]``: ``phi_k = sum_i V_i(h_k < z < h_k+1) / (A (h_k+1 - h_k))`` where
  ``V_i(...)`` is the exact part of particle ``i`` inside the slab
  (:func:`analysis.geometry.measure_below`) and ``A`` the horizontal cross-section of
  the container (box area by default; pass ``area`` for a cylinder);
* filled part: ``phi_fill = sum_i V_i(z < H) / (A (H - z_0))`` with ``z_0`` the bottom
  and ``H`` the top surface of the grains: the mean over horizontal columns (squares of
  side ``column`` in 3-D, intervals in 2-D) of the highest grain surface point whose
  centre lies in the column;
* enclosing cylinder (Pournin et al. 2005, section 4: "the total volume occupied by the
  grains divided by the volume of the enclosing truncated cylinder (upon elimination of
  outliers)"): ``phi_enc = sum_{i in bed} V_i / (A (z_top - z_bot))`` with ``z_bot`` and
  ``z_top`` the lowest and highest surface points of the bed's grains; outliers are the
  grains above the first empty horizontal gap (:func:`bed_grains`);
* how a slab profile changes with height (:func:`profile_change`), and whether it is
  uniform (within :data:`UNIFORM_PROFILE`).

The vertical axis is ``z`` in 3-D and ``y`` in 2-D (:attr:`analysis.frame.Frame.vertical`).
"""
from __future__ import annotations

import numpy as np

from analysis.base import Observable
from analysis.frame import Frame
from analysis.geometry import measure_below


def packing_fraction(frame: Frame) -> float:
    """Global packing fraction ``phi = sum_i V_i / V_box`` (spherocylinder volumes; in
    2-D areas over the box area)."""
    return float(np.sum(frame.particle_measures()) / frame.measure)


def horizontal_area(frame: Frame, axis: int | None = None) -> float:
    """Cross-section of the box perpendicular to ``axis`` (2-D: a length)."""
    axis = frame.vertical if axis is None else axis
    others = [k for k in range(frame.dim) if k != axis]
    return float(np.prod(frame.box[others]))


def _images(frame: Frame, axis: int):
    """Centres and axis components along ``axis``, with periodic images of particles
    sticking out of the box so that slabs inside the box get every part."""
    lo, length = frame.box_lo[axis], frame.box[axis]
    c = frame.x[:, axis].copy()
    rows = np.arange(frame.n)
    if frame.periodic[axis]:
        c = lo + np.mod(c - lo, length)
        half = 0.5 * frame.length * np.abs(frame.axis[:, axis]) + frame.radius
        below = c - half < lo
        above = c + half > lo + length
        c = np.concatenate([c, c[below] + length, c[above] - length])
        rows = np.concatenate([rows, rows[below], rows[above]])
    return c, rows


def cumulative_measure(frame: Frame, levels, axis: int | None = None) -> np.ndarray:
    """``F(h)`` (K,): total grain volume (2-D area) below each level ``h`` along ``axis``
    (default vertical), exact; periodic images are included on a periodic axis."""
    axis = frame.vertical if axis is None else axis
    levels = np.atleast_1d(np.asarray(levels, dtype=np.float64))
    c, rows = _images(frame, axis)
    uv = frame.axis[rows, axis]
    r = frame.radius[rows]
    ln = frame.length[rows]
    half = 0.5 * ln * np.abs(uv) + r
    lo, hi = c - half, c + half
    full = frame.particle_measures()[rows]
    order = np.argsort(hi)
    done = np.concatenate([[0.0], np.cumsum(full[order])])
    out = done[np.searchsorted(hi[order], levels, side="right")]
    # particles cut by a level: exact partial measure
    p, k = np.nonzero((lo[:, None] < levels[None, :]) & (levels[None, :] < hi[:, None]))
    if len(p):
        part = measure_below(c[p], uv[p], r[p], ln[p], levels[k], frame.dim)
        np.add.at(out, k, part)
    return out


def slab_measures(frame: Frame, edges, axis: int | None = None) -> np.ndarray:
    """Grain volume (2-D area) inside each slab between consecutive ``edges`` (K-1,)."""
    edges = _check_edges(edges)
    return np.diff(cumulative_measure(frame, edges, axis))


def slab_packing_fraction(frame: Frame, edges, axis: int | None = None,
                          area: float | None = None) -> np.ndarray:
    """Packing fraction of each slab between consecutive ``edges`` (K-1,):
    grain volume in the slab over ``area * thickness`` (``area`` defaults to the box
    cross-section)."""
    edges = _check_edges(edges)
    area = horizontal_area(frame, axis) if area is None else float(area)
    if area <= 0:
        raise ValueError(f"area must be > 0, got {area}")
    return slab_measures(frame, edges, axis) / (area * np.diff(edges))


#: the largest change of the packing fraction from the base to the top of a deposit (of
#: the fitted straight line, :func:`profile_change`) that still counts as uniform
UNIFORM_PROFILE = 0.02


def profile_change(heights, phi, top: float, inner=(0.1, 0.9)) -> float:
    """Change of a packing-fraction profile up a deposit: ``phi`` of slabs centred at
    ``heights`` above the base, fitted by a straight line in ``y / top`` over the slabs
    with ``inner[0] <= y / top <= inner[1]`` (leaving out the layer ordered by the base
    and the loose surface); returns the line's rise across that range,
    ``slope * (inner[1] - inner[0])`` (positive: denser at the top). NaN with fewer
    than 3 slabs in the range."""
    lo, hi = (float(v) for v in inner)
    if not (0.0 <= lo < hi <= 1.0) or not top > 0:
        raise ValueError(f"need 0 <= inner[0] < inner[1] <= 1 and top > 0, got {inner}, {top}")
    y = np.asarray(heights, dtype=np.float64) / top
    phi = np.asarray(phi, dtype=np.float64)
    keep = (y >= lo) & (y <= hi) & np.isfinite(phi)
    if keep.sum() < 3:
        return float("nan")
    slope = np.polyfit(y[keep], phi[keep], 1)[0]
    return float(slope * (hi - lo))


def _check_edges(edges) -> np.ndarray:
    edges = np.asarray(edges, dtype=np.float64)
    if edges.ndim != 1 or len(edges) < 2 or np.any(np.diff(edges) <= 0):
        raise ValueError(f"slab edges must be at least two strictly increasing values, got "
                         f"{np.array2string(edges[:6])}")
    return edges


def layer_edges(bottom: float, thickness: float, n_layers: int) -> np.ndarray:
    """Edges of ``n_layers`` layers of the given ``thickness`` stacked from ``bottom``
    (e.g. the four 4 mm layers of the tapping study)."""
    if thickness <= 0 or n_layers < 1:
        raise ValueError(f"need thickness > 0 and n_layers >= 1, got {thickness}, {n_layers}")
    return bottom + thickness * np.arange(n_layers + 1)


def surface_height(frame: Frame, axis: int | None = None, column: float | None = None,
                   method: str = "columns") -> float:
    """Height of the top surface of the grains along ``axis`` (default vertical).

    ``method="columns"``: mean over horizontal columns of side ``column`` (default the
    largest particle extent ``L + D``) of the highest surface point among the particles
    whose centre lies in the column; ``"max"``: the highest surface point of all.
    """
    axis = frame.vertical if axis is None else axis
    if frame.n == 0:
        raise ValueError("no particles: the surface height is undefined")
    top = frame.extent(axis)[1]
    if method == "max":
        return float(top.max())
    if method != "columns":
        raise ValueError(f"method must be 'columns' or 'max', got {method!r}")
    column = float(np.max(frame.length + 2 * frame.radius)) if column is None else float(column)
    if column <= 0:
        raise ValueError(f"column must be > 0, got {column}")
    others = [k for k in range(frame.dim) if k != axis]
    rel = (frame.x[:, others] - frame.box_lo[others])
    rel = np.where(frame.periodic[others], np.mod(rel, frame.box[others]), rel)
    ncell = np.maximum(np.round(frame.box[others] / column).astype(int), 1)
    cell = np.clip(np.floor(rel / frame.box[others] * ncell).astype(int), 0, ncell - 1)
    key = np.ravel_multi_index(tuple(cell.T), tuple(ncell))
    best = np.full(int(np.prod(ncell)), -np.inf)
    np.maximum.at(best, key, top)
    return float(best[np.isfinite(best)].mean())


class PackingProfile(Observable):
    """Density profile: packing fraction in horizontal slabs.

    Parameters: ``thickness`` of the slabs (from the bottom of the box up to its top)
    or explicit ``edges``; ``axis`` (default vertical); ``area`` of the container
    cross-section (default the box's). Results: ``edges`` (K+1,), ``centers`` (K,),
    ``phi`` (K,), ``grain_measure`` (K,) grain volume (2-D area) per slab, ``depth``
    (K,) distance of the slab centres below the top surface (:func:`surface_height`).
    """

    _results = ("edges", "centers", "phi", "grain_measure", "depth")

    def __init__(self, thickness: float | None = None, edges=None, axis: int | None = None,
                 area: float | None = None):
        if (thickness is None) == (edges is None):
            raise ValueError("give exactly one of thickness or edges")
        if thickness is not None and thickness <= 0:
            raise ValueError(f"thickness must be > 0, got {thickness}")
        self.thickness = thickness
        self.slab_edges = None if edges is None else _check_edges(edges)
        self.axis = axis
        self.area = area

    def compute(self, frame: Frame, contacts=None):
        axis = frame.vertical if self.axis is None else self.axis
        if self.slab_edges is not None:
            edges = self.slab_edges
        else:
            lo, hi = frame.box_lo[axis], frame.box_lo[axis] + frame.box[axis]
            k = max(int(np.floor((hi - lo) / self.thickness + 1e-9)), 1)
            edges = lo + self.thickness * np.arange(k + 1)
        area = horizontal_area(frame, axis) if self.area is None else float(self.area)
        m = slab_measures(frame, edges, axis)
        centers = 0.5 * (edges[1:] + edges[:-1])
        self._set(edges=edges, centers=centers, phi=m / (area * np.diff(edges)), grain_measure=m,
                  depth=surface_height(frame, axis) - centers)
        return self


class FilledPackingFraction(Observable):
    """Packing fraction of the filled part of a container (tapping study).

    ``phi_fill = sum_i V_i(z < H) / (A (H - z_0))``: ``z_0`` = ``bottom`` (default the
    box bottom), ``H`` the top surface (:func:`surface_height` with ``column`` and
    ``method``), ``A`` = ``area`` (default the box cross-section; a cylinder of diameter
    ``D_c``: ``pi D_c^2 / 4``). Results: ``phi``, ``top`` ``H``, ``height`` ``H - z_0``,
    ``grain_measure`` (grain volume below ``H``).
    """

    _results = ("phi", "top", "height", "grain_measure")

    def __init__(self, bottom: float | None = None, area: float | None = None,
                 column: float | None = None, method: str = "columns", axis: int | None = None):
        if method not in ("columns", "max"):
            raise ValueError(f"method must be 'columns' or 'max', got {method!r}")
        self.bottom, self.area, self.column, self.method, self.axis = bottom, area, column, method, axis

    def compute(self, frame: Frame, contacts=None):
        axis = frame.vertical if self.axis is None else self.axis
        bottom = frame.box_lo[axis] if self.bottom is None else float(self.bottom)
        area = horizontal_area(frame, axis) if self.area is None else float(self.area)
        top = surface_height(frame, axis, self.column, self.method)
        if top <= bottom:
            raise ValueError(f"top surface {top:.6g} is not above the bottom {bottom:.6g}")
        below = float(cumulative_measure(frame, [top], axis)[0] - cumulative_measure(frame, [bottom], axis)[0])
        self._set(phi=below / (area * (top - bottom)), top=top, height=top - bottom,
                  grain_measure=below)
        return self


def bed_grains(frame: Frame, axis: int | None = None) -> np.ndarray:
    """Boolean mask of the grains of the bed: the grains whose height ranges
    ``[lo_i, hi_i]`` (:meth:`analysis.frame.Frame.extent`) chain up from the lowest grain
    without a gap. Sorted by ``lo``, grain ``k`` belongs to the bed when ``lo_k`` is not
    above the highest ``hi`` of the grains before it; the first grain that is starts the
    outliers, and every grain after it is one too: a horizontal plane separates them
    from the bed, so they touch nothing in it (grains thrown up by a tap). A grain
    detached from the bed whose height range overlaps the bed's is kept: it does not
    raise the top of the enclosing cylinder by more than its own extent."""
    axis = frame.vertical if axis is None else axis
    lo, hi = frame.extent(axis)
    order = np.argsort(lo, kind="stable")
    reach = np.maximum.accumulate(hi[order])
    gap = np.flatnonzero(lo[order][1:] > reach[:-1])
    keep = np.zeros(frame.n, bool)
    keep[order[:gap[0] + 1 if len(gap) else frame.n]] = True
    return keep


class EnclosingPackingFraction(Observable):
    """Volumetric density of Pournin et al. (2005, section 4): the volume of the grains
    of the bed over the volume of the enclosing truncated cylinder (tapping study).

    ``phi = sum_{i in bed} V_i / (A (z_top - z_bot))``: the bed and its outliers as
    :func:`bed_grains` defines them, ``z_bot`` and ``z_top`` the lowest and highest
    surface points of the bed's grains, ``A`` = ``area`` (default the box cross-section;
    a cylinder of diameter ``D_c``: ``pi D_c^2 / 4``). Unlike
    :class:`FilledPackingFraction` the whole of every bed grain counts, the top is the
    highest point rather than the mean surface, and the bottom is the lowest grain, not
    the base (a bed in flight is not diluted by the gap under it). Results: ``phi``,
    ``bottom``, ``top``, ``height``, ``grain_measure`` (of the bed), ``outliers``
    (grains left out).
    """

    _results = ("phi", "bottom", "top", "height", "grain_measure", "outliers")

    def __init__(self, area: float | None = None, axis: int | None = None):
        self.area, self.axis = area, axis

    def compute(self, frame: Frame, contacts=None):
        axis = frame.vertical if self.axis is None else self.axis
        if frame.n == 0:
            raise ValueError("no particles: the enclosing cylinder is undefined")
        area = horizontal_area(frame, axis) if self.area is None else float(self.area)
        bed = bed_grains(frame, axis)
        lo, hi = frame.extent(axis)
        bottom, top = float(lo[bed].min()), float(hi[bed].max())
        measure = float(np.sum(frame.particle_measures()[bed]))
        self._set(phi=measure / (area * (top - bottom)), bottom=bottom, top=top,
                  height=top - bottom, grain_measure=measure, outliers=int(frame.n - bed.sum()))
        return self


def period_average(values, samples_per_period: int) -> np.ndarray:
    """Centred mean over exactly one period of a signal sampled ``samples_per_period``
    (``f``) times per period: the kernel is ``f`` equal weights for odd ``f`` and, for even
    ``f``, ``f - 1`` equal weights plus half weights at both ends (the trapezoid over one
    period), so a signal periodic in the samples averages to a constant. Near the ends and
    around NaN samples the kernel is renormalised over the finite samples it covers."""
    values = np.asarray(values, dtype=np.float64)
    f = int(samples_per_period)
    if f < 1:
        raise ValueError(f"samples_per_period must be >= 1, got {samples_per_period}")
    kernel = np.ones(f + 1 if f % 2 == 0 else f)
    if f % 2 == 0:
        kernel[[0, -1]] = 0.5
    ok = np.isfinite(values)
    centre = slice(len(kernel) // 2, len(kernel) // 2 + len(values))  # odd, symmetric kernel
    num = np.convolve(np.where(ok, values, 0.0), kernel)[centre]
    den = np.convolve(ok.astype(np.float64), kernel)[centre]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
