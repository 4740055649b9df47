"""Orientational order of rods (science.md section 5).

* 2-D: ``S_n = |<exp(i n theta)>|`` with ``theta`` the spine angle in the x-y plane;
  ``n = 2`` nematic, ``n = 4`` tetratic; the director angle ``psi_n = arg<exp(i n
  theta)> / n``; ``sqrt(N) S_n`` (disorder gives ``S_n ~ 1/sqrt(N)``, and
  ``<N S_n^2> = 1`` exactly for independent uniform angles).
* 3-D (and 2-D): ``Q = <(d u u - I) / (d - 1)>``, its largest eigenvalue ``S`` and the
  director (its eigenvector): ``Q = diag(1, -1/2, -1/2)`` for rods all along x.
* With respect to gravity: ``<P2(cos theta_v)> = <(3 u_v^2 - 1)/2>`` in 3-D,
  ``<cos 2 theta_v> = <2 u_v^2 - 1>`` in 2-D (``theta_v`` angle to the vertical).
* Angle to the horizontal ``beta = asin|u_v|`` in ``[0, pi/2]``: its histogram
  ``f(beta)`` (isotropic 3-D: ``f = cos beta``), its mean (the mean angle between
  shafts and the bottom plane), globally and in horizontal layers (by centre).
  Its mode (:func:`orientation_mode`) and the share of standing rods
  (:func:`standing_fraction`).
* Radial orientation correlation ``Q(r)``: mean over pairs at centre distance ``r`` of
  ``cos 2(theta_i - theta_j) = 2 (u_i.u_j)^2 - 1`` (2-D) or
  ``P2(u_i.u_j) = (3 (u_i.u_j)^2 - 1)/2`` (3-D); a peak of it in a window
  (:func:`correlation_peak`) and its range of values (:func:`correlation_amplitude`).
"""
from __future__ import annotations

import numpy as np

from analysis.base import Observable
from analysis.frame import Frame


def spine_angles(frame: Frame) -> np.ndarray:
    """In-plane spine angles ``theta = atan2(u_y, u_x)`` (N,) of a 2-D frame (radians)."""
    return np.arctan2(frame.axis[:, 1], frame.axis[:, 0])


def order_parameter_2d(theta, n: int) -> tuple[float, float]:
    """``(S_n, psi_n)``: ``S_n = |<exp(i n theta)>|`` and the director angle
    ``psi_n = arg<exp(i n theta)> / n`` (radians, in ``(-pi/n, pi/n]``)."""
    theta = np.asarray(theta, dtype=np.float64)
    if n < 1:
        raise ValueError(f"n must be a positive integer, got {n}")
    if theta.size == 0:
        raise ValueError("no angles: the order parameter is undefined")
    z = np.mean(np.exp(1j * n * theta))
    return float(abs(z)), float(np.angle(z) / n)


def q_tensor(axis, dim: int = 3) -> np.ndarray:
    """``Q = <(d u u - I)/(d - 1)>`` (d, d) of unit vectors ``axis`` (N, >= d)."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    u = np.asarray(axis, dtype=np.float64)[:, :dim]
    if len(u) == 0:
        raise ValueError("no orientations: Q is undefined")
    u = u / np.linalg.norm(u, axis=1)[:, None]
    return (dim * np.einsum("ia,ib->ab", u, u) / len(u) - np.eye(dim)) / (dim - 1)


def nematic_order(axis, dim: int = 3) -> tuple[float, np.ndarray, np.ndarray]:
    """``(S, director, Q)``: the largest eigenvalue of :func:`q_tensor`, its unit
    eigenvector and the tensor."""
    q = q_tensor(axis, dim)
    w, v = np.linalg.eigh(q)
    return float(w[-1]), v[:, -1], q


def angle_to_horizontal(frame: Frame, axis: int | None = None) -> np.ndarray:
    """``beta = asin(|u_v|)`` (N,) in ``[0, pi/2]``: angle between each spine and the
    horizontal (bottom) plane (radians)."""
    axis = frame.vertical if axis is None else axis
    return np.arcsin(np.clip(np.abs(frame.axis[:, axis]), 0.0, 1.0))


#: a rod within this angle (degrees) of the vertical stands; within it of the horizontal it lies
UPRIGHT_WITHIN = 15.0


def orientation_mode(beta, bins: int = 18) -> float:
    """Most probable angle to the horizontal (degrees): the centre of the fullest of
    ``bins`` equal bins over ``[0, 90]`` degrees of ``beta`` (radians, in ``[0, pi/2]``;
    the lowest such bin on a tie)."""
    beta = np.asarray(beta, dtype=np.float64)
    if beta.size == 0:
        raise ValueError("no angles: the most probable orientation is undefined")
    if bins < 1:
        raise ValueError(f"bins must be >= 1, got {bins}")
    count, edges = np.histogram(np.degrees(beta), bins=bins, range=(0.0, 90.0))
    k = int(np.argmax(count))
    return float(0.5 * (edges[k] + edges[k + 1]))


def standing_fraction(beta, within: float = UPRIGHT_WITHIN) -> float:
    """Share of rods standing: ``beta`` (radians, angle to the horizontal) within
    ``within`` degrees of the vertical."""
    beta = np.asarray(beta, dtype=np.float64)
    if beta.size == 0:
        raise ValueError("no angles: the share of standing rods is undefined")
    return float(np.mean(beta > np.radians(90.0 - within)))


def _window(centers, q, lo: float, hi: float):
    """``(centers, q, k)`` as arrays and the indices ``k`` of the non-empty shells with
    centres in ``[lo, hi]``."""
    centers, q = np.asarray(centers, dtype=np.float64), np.asarray(q, dtype=np.float64)
    if not lo < hi:
        raise ValueError(f"the window needs lo < hi, got [{lo}, {hi}]")
    return centers, q, np.flatnonzero((centers >= lo) & (centers <= hi) & np.isfinite(q))


def correlation_peak(centers, q, lo: float, hi: float, err=None) -> float:
    """Where a correlation ``q(r)`` peaks inside ``[lo, hi]``: the centre of its largest
    shell there, if that shell is neither the first nor the last of the window and
    stands above both by more than twice its standard error ``err`` (zero if None);
    NaN when ``q`` runs up or down through the window, or fewer than 3 shells hold
    pairs. Same units as ``centers``."""
    centers, q, k = _window(centers, q, lo, hi)
    if len(k) < 3:
        return float("nan")
    top = k[int(np.argmax(q[k]))]
    margin = 0.0 if err is None else 2.0 * float(np.asarray(err, dtype=np.float64)[top])
    if top in (k[0], k[-1]) or not q[top] - margin > max(q[k[0]], q[k[-1]]):
        return float("nan")
    return float(centers[top])


def correlation_amplitude(centers, q, lo: float, hi: float) -> float:
    """Height of the highest maximum above the deepest minimum of ``q(r)`` over the
    shells with centres in ``[lo, hi]`` (empty shells skipped; NaN if none)."""
    _, q, k = _window(centers, q, lo, hi)
    if len(k) == 0:
        return float("nan")
    return float(q[k].max() - q[k].min())


def _rods(frame: Frame) -> np.ndarray:
    return frame.length > 0


class OrientationOrder2D(Observable):
    """Nematic (``n = 2``) and tetratic (``n = 4``) order of a 2-D packing.

    ``rods_only`` (default True) leaves out disks (``L = 0``), which have no
    orientation. Results: ``S2``, ``S4``, director angles ``psi2``, ``psi4`` (radians),
    ``sqrtN_S2``, ``sqrtN_S4`` (``sqrt(N) S_n``), ``n`` (particles used).
    """

    _results = ("S2", "S4", "psi2", "psi4", "sqrtN_S2", "sqrtN_S4", "n")

    def __init__(self, rods_only: bool = True):
        self.rods_only = rods_only

    def compute(self, frame: Frame, contacts=None):
        if frame.dim != 2:
            raise ValueError("OrientationOrder2D needs a 2-D frame (z = 0, spines in the x-y "
                             "plane); use NematicOrder for 3-D")
        sel = _rods(frame) if self.rods_only else np.ones(frame.n, bool)
        theta = spine_angles(frame)[sel]
        s2, p2 = order_parameter_2d(theta, 2)
        s4, p4 = order_parameter_2d(theta, 4)
        root = np.sqrt(len(theta))
        self._set(S2=s2, S4=s4, psi2=p2, psi4=p4, sqrtN_S2=root * s2, sqrtN_S4=root * s4,
                  n=len(theta))
        return self


class NematicOrder(Observable):
    """Nematic order from the ``Q`` tensor, and order with respect to gravity.

    Results: ``Q`` (d, d), ``S`` (largest eigenvalue), ``director`` (d,) unit vector,
    ``eigenvalues`` (ascending), ``gravity_order`` (3-D ``<P2(u_z)>``, 2-D
    ``<2 u_y^2 - 1>``), ``n``. ``rods_only`` as in :class:`OrientationOrder2D`.
    """

    _results = ("Q", "S", "director", "eigenvalues", "gravity_order", "n")

    def __init__(self, rods_only: bool = True):
        self.rods_only = rods_only

    def compute(self, frame: Frame, contacts=None):
        d = frame.dim
        sel = _rods(frame) if self.rods_only else np.ones(frame.n, bool)
        u = frame.axis[sel]
        q = q_tensor(u, d)
        w, v = np.linalg.eigh(q)
        uv2 = u[:, frame.vertical] ** 2
        grav = np.mean((3 * uv2 - 1) / 2) if d == 3 else np.mean(2 * uv2 - 1)
        self._set(Q=q, S=float(w[-1]), director=v[:, -1], eigenvalues=w,
                  gravity_order=float(grav), n=int(sel.sum()))
        return self


class AngleToHorizontal(Observable):
    """Distribution of the angle ``beta`` between spines and the horizontal plane.

    Parameters: ``bins`` over ``[0, pi/2]``; ``layers`` edges along the vertical axis
    (e.g. :func:`analysis.packing.layer_edges`) for the mean angle per layer (particles
    assigned by centre). Results: ``angles`` (N,) radians, ``edges``, ``density``
    ``f(beta)`` (integrates to 1 over ``[0, pi/2]``), ``mean`` (radians),
    ``mean_deg``, ``layer_mean`` (K,) radians (nan for an empty layer),
    ``layer_count`` (K,).
    """

    _results = ("angles", "edges", "density", "mean", "mean_deg", "layer_mean", "layer_count")

    def __init__(self, bins: int = 18, layers=None, rods_only: bool = True):
        if bins < 1:
            raise ValueError(f"bins must be >= 1, got {bins}")
        self.bins = bins
        self.layers = None if layers is None else np.asarray(layers, dtype=np.float64)
        if self.layers is not None and (self.layers.ndim != 1 or len(self.layers) < 2 or
                                        np.any(np.diff(self.layers) <= 0)):
            raise ValueError("layers must be at least two increasing edges")
        self.rods_only = rods_only

    def compute(self, frame: Frame, contacts=None):
        sel = _rods(frame) if self.rods_only else np.ones(frame.n, bool)
        beta = angle_to_horizontal(frame)[sel]
        if len(beta) == 0:
            raise ValueError("no rods in the frame: the angle to the horizontal is undefined")
        dens, edges = np.histogram(beta, bins=self.bins, range=(0.0, 0.5 * np.pi), density=True)
        mean = float(beta.mean())
        if self.layers is not None:
            z = frame.x[sel, frame.vertical]
            k = np.searchsorted(self.layers, z, side="right") - 1
            ok = (k >= 0) & (k < len(self.layers) - 1)
            cnt = np.bincount(k[ok], minlength=len(self.layers) - 1)
            tot = np.bincount(k[ok], weights=beta[ok], minlength=len(self.layers) - 1)
            with np.errstate(invalid="ignore", divide="ignore"):
                lm = np.where(cnt > 0, tot / np.maximum(cnt, 1), np.nan)
        else:
            cnt, lm = np.zeros(0, int), np.zeros(0)
        self._set(angles=beta, edges=edges, density=dens, mean=mean, mean_deg=np.degrees(mean),
                  layer_mean=lm, layer_count=cnt)
        return self


class OrientationCorrelation(Observable):
    """Radial orientation correlation ``Q(r)`` (module docstring).

    Pairs of rods with centre distance below ``r_max`` (minimum image) are binned in
    ``bins`` equal shells. Results: ``edges``, ``centers``, ``q`` (mean per shell, nan
    where empty), ``q_err`` (its standard error, the spread of the pairs' values over the
    root of their count: pairs sharing a rod are not independent, so it is a lower
    bound), ``counts`` (pairs per shell).
    """

    _results = ("edges", "centers", "q", "q_err", "counts")

    def __init__(self, r_max: float, bins: int = 50, rods_only: bool = True):
        if not r_max > 0 or bins < 1:
            raise ValueError(f"need r_max > 0 and bins >= 1, got {r_max}, {bins}")
        self.r_max, self.bins, self.rods_only = float(r_max), int(bins), rods_only

    def compute(self, frame: Frame, contacts=None):
        from analysis.contacts import pairs_within

        fr = frame.subset(_rods(frame)) if self.rods_only else frame
        a, b = pairs_within(fr, self.r_max)
        r = np.linalg.norm(fr.minimum_image(fr.x[b] - fr.x[a]), axis=1)
        c = np.sum(fr.axis[a] * fr.axis[b], axis=1)
        val = 2 * c**2 - 1 if frame.dim == 2 else (3 * c**2 - 1) / 2
        edges = np.linspace(0.0, self.r_max, self.bins + 1)
        cnt, _ = np.histogram(r, bins=edges)
        tot, _ = np.histogram(r, bins=edges, weights=val)
        sq, _ = np.histogram(r, bins=edges, weights=val * val)
        with np.errstate(invalid="ignore", divide="ignore"):
            q = np.where(cnt > 0, tot / np.maximum(cnt, 1), np.nan)
            var = np.clip(sq / np.maximum(cnt, 1) - q * q, 0.0, None) * cnt / (cnt - 1.0)
            err = np.where(cnt > 1, np.sqrt(var / np.maximum(cnt, 1)), np.nan)
        self._set(edges=edges, centers=0.5 * (edges[1:] + edges[:-1]), q=q, q_err=err,
                  counts=cnt)
        return self


def finite_size_order(curves, phi_min: float = 0.0):
    """Finite-size scaling of the 2-D orientational order along compressions.

    ``curves``: a table (pandas) with one row per frame and columns ``alpha``, ``n``,
    ``seed``, ``phi``, ``sqrt_n_s2``, ``sqrt_n_s4`` (:func:`analysis.summary.frame_curves`
    with the run's aspect ratio and seed). Each run (seed) gives one sample: the mean of
    ``sqrt(N) S_n`` over its frames with ``phi >= phi_min`` (the frames of one run are
    strongly correlated: the orientations of the start persist). Per aspect ratio and
    particle number: ``seeds``, ``frames``, ``mean_sqrt_n_s2`` and its standard error
    over the seeds ``sem_sqrt_n_s2``, ``rms_sqrt_n_s2`` (root mean square of the
    samples), ``mean_s2`` (``<S_2>`` = ``mean_sqrt_n_s2 / sqrt(N)``) and ``sem_s2``, and
    the same for ``S_4``. A disordered state has ``S_n ~ 1/sqrt(N)``: ``sqrt(N) S_n`` stays
    of order 1 as N grows (independent uniform angles: mean ``sqrt(pi)/2``, rms 1),
    while an ordered one keeps ``S_n`` (``sqrt(N) S_n`` grows as ``sqrt(N)``)."""
    import pandas as pd

    df = curves[(curves.phi >= phi_min) & curves.sqrt_n_s2.notna()]
    rows = []
    for (alpha, n), g in df.groupby(["alpha", "n"], sort=True):
        runs = g.groupby("seed")[["sqrt_n_s2", "sqrt_n_s4"]].mean()
        k = len(runs)
        row = {"alpha": float(alpha), "n": int(n), "seeds": k, "frames": len(g)}
        for m in ("s2", "s4"):
            x = runs[f"sqrt_n_{m}"].to_numpy(dtype=float)
            sem = float(np.std(x, ddof=1) / np.sqrt(k)) if k > 1 else float("nan")
            row[f"mean_sqrt_n_{m}"] = float(np.mean(x))
            row[f"sem_sqrt_n_{m}"] = sem
            row[f"rms_sqrt_n_{m}"] = float(np.sqrt(np.mean(x * x)))
            row[f"mean_{m}"] = float(np.mean(x) / np.sqrt(n))
            row[f"sem_{m}"] = sem / float(np.sqrt(n))
        rows.append(row)
    return pd.DataFrame(rows)
