"""Make the figures of docs/analysis.md (one PNG per section, a few seconds each).

    .venv/bin/python docs/figures/make_analysis_figures.py [--only NAME ...]

Every panel is computed with the analysis package on a configuration built here: a
short pysim compression of 300 spheres to just above jamming (packing fraction and
contact numbers, stress, jamming point), constructed lattices and random sequential
placements (profiles, orientation, contact types), synthetic profiles (Janssen) and
Monte-Carlo runs (caging number). Nothing is read from results/.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from analysis import theory  # noqa: E402
from analysis.caging import CagingNumber  # noqa: E402
from analysis.contacts import (TYPE_NAMES, ContactNumber, ContactTypes,  # noqa: E402
                               contact_types, geometric_contacts)
from analysis.frame import Contacts, Frame  # noqa: E402
from analysis.jamming import JammingPoint  # noqa: E402
from analysis.janssen import JanssenFit, janssen  # noqa: E402
from analysis.order import (AngleToHorizontal, NematicOrder, OrientationCorrelation,  # noqa: E402
                            OrientationOrder2D, order_parameter_2d)
from analysis.packing import (FilledPackingFraction, PackingProfile,  # noqa: E402
                              layer_edges, slab_packing_fraction)
from analysis.stress import StressField, StressProfile  # noqa: E402
from analysis.walls import PlaneWall, wall_contacts  # noqa: E402

OUT = Path(__file__).resolve().parent
DPI = 90
FIGS = {}


def figure(fn):
    FIGS[fn.__name__.removeprefix("fig_")] = fn
    return fn


def save(fig, name):
    fig.tight_layout()
    fig.savefig(OUT / f"{name}.png", dpi=DPI)
    plt.close(fig)


# -- configurations -------------------------------------------------------------------------
_JAMMED = {}


def jammed_spheres():
    """300 monodisperse spheres compressed with pysim (linear contacts, k_n = 1e5): fast
    from phi = 0.3 to 0.55 (true strain rate 0.1), then slowly (0.004) to 0.68, thermo
    and a frame every 1000 steps; the frame kept is the last one of the fitted pressure
    rise (p ~ 1e-3 k_n / D), a rigid network just above jamming."""
    if _JAMMED:
        return _JAMMED
    from pysim import State
    from pysim.initial import random_spheres
    from pysim.simulation import ContactModel, Simulation

    x, d, box = random_spheres(np.ones(300), 0.3, seed=2)
    st = State.spheres(x, d / 2, box)
    sim = Simulation(st, ContactModel("hooke", 1e5, 50.0, gamma_bg=1.0), dt=1e-4)
    sim.run(round(np.log(0.55 / 0.3) / (3 * 0.1 * 1e-4)), strain_rate=-0.1)
    phi, p, frames = [], [], []
    ids = np.arange(1, st.n + 1)
    while sim.thermo().phi < 0.68:
        sim.run(1000, strain_rate=-0.004)
        th = sim.thermo()
        phi.append(th.phi)
        p.append(th.pressure)
        ij, rec = sim.contact_table()
        frames.append((Frame.from_arrays(st.x.copy(), st.radius.copy(), st.box.copy(), step=st.step),
                       Contacts(st.step, ids[ij[:, 0]], ids[ij[:, 1]], rec[:, 0:3], rec[:, 3:6],
                                rec[:, 6], rec[:, 7:10])))
    phi, p = np.array(phi), np.array(p)
    jp = JammingPoint(window=(1e-4, 1e-3), p_scale=1e5).compute(phi, p)
    k = jp.rows.stop - 1
    _JAMMED.update(frame=frames[k][0], contacts=frames[k][1], phi=phi, p=p, fit=jp)
    return _JAMMED


def rsa_rods_2d(n, alpha, box, seed, max_tries=200000):
    """Random sequential placement of 2-D rods (D = 1, L = alpha) without overlap."""
    from analysis.geometry import spine_closest

    rng = np.random.default_rng(seed)
    xs, us = [], []
    for _ in range(max_tries):
        if len(xs) == n:
            break
        x = np.r_[rng.uniform(0, box, 2), 0.0]
        t = rng.uniform(0, np.pi)
        u = np.array([np.cos(t), np.sin(t), 0.0])
        if xs:
            xa = np.array(xs)
            d = x - xa
            d -= box * np.round(d / box) * np.array([1, 1, 0])
            near = np.linalg.norm(d, axis=1) < alpha + 1.0
            if near.any():
                m = int(near.sum())
                s, tt = spine_closest(np.tile(x, (m, 1)), np.tile(u, (m, 1)), np.full(m, alpha),
                                      x - d[near], np.array(us)[near], np.full(m, alpha))
                gap = np.linalg.norm(x + s[:, None] * u - (x - d[near]) - tt[:, None] * np.array(us)[near],
                                     axis=1)
                if np.any(gap < 1.0):
                    continue
        xs.append(x)
        us.append(u)
    return Frame.from_arrays(np.array(xs), 0.5, [box, box, 1.0], axis=np.array(us), length=alpha,
                             dimension=2)


def stadium(ax, x, u, r, ln, **kw):
    t = np.linspace(-np.pi / 2, np.pi / 2, 20)
    perp = np.array([-u[1], u[0]])
    e1 = x[:2] + 0.5 * ln * u[:2]
    e0 = x[:2] - 0.5 * ln * u[:2]
    ang = np.arctan2(u[1], u[0])
    cap1 = e1 + r * np.column_stack([np.cos(ang + t), np.sin(ang + t)])
    cap0 = e0 + r * np.column_stack([np.cos(ang + np.pi + t), np.sin(ang + np.pi + t)])
    pts = np.vstack([cap1, cap0, cap1[:1]])
    ax.fill(pts[:, 0], pts[:, 1], **kw)
    del perp


# -- figures --------------------------------------------------------------------------------
@figure
def fig_packing():
    """Density profile of a layered bed near a floor (thin and thick slabs), per-layer
    values and the filled part of the container."""
    rng = np.random.default_rng(1)
    # spheres D = 1 in square layers 1 apart; occupancy falls off above 8 layers
    g = np.array(np.meshgrid(np.arange(10), np.arange(10), np.arange(12), indexing="ij")).reshape(3, -1).T
    keep = rng.random(len(g)) < np.clip(1.2 - 0.1 * g[:, 2], 0, 1)
    x = g[keep] + 0.5 + rng.normal(0, 0.03, (keep.sum(), 3)) * [1, 1, 0]
    fr = Frame.from_arrays(x, 0.5, [10.0, 10.0, 14.0], periodic=(True, True, False))
    thin = PackingProfile(thickness=0.05).compute(fr)
    thick = PackingProfile(thickness=1.0).compute(fr)
    lay = layer_edges(0.0, 3.0, 4)
    phil = slab_packing_fraction(fr, lay)
    fill = FilledPackingFraction(column=1.0).compute(fr)
    fig, axs = plt.subplots(1, 2, figsize=(8.5, 3.2))
    axs[0].plot(thin.centers, thin.phi, lw=0.8, label="slabs 0.05 D")
    axs[0].step(thick.edges[1:], thick.phi, where="pre", label="slabs 1 D")
    axs[0].set(xlabel="height z / D", ylabel="slab packing fraction", title="profile phi(z)")
    axs[0].legend(fontsize=8)
    axs[1].bar(0.5 * (lay[1:] + lay[:-1]), phil, width=2.8, alpha=0.6, label="layers 3 D")
    axs[1].axvline(fill.top, color="k", ls="--", label=f"top surface H = {fill.top:.2f}")
    axs[1].axhline(fill.phi, color="C3", label=f"filled part phi = {fill.phi:.3f}")
    axs[1].set(xlabel="height z / D", ylabel="packing fraction", title="layers, filled part")
    axs[1].legend(fontsize=8)
    save(fig, "packing")


@figure
def fig_contacts():
    """P(C) of a jammed sphere packing with and without rattlers; contact types in a
    random 2-D rod placement (near-contacts within 0.1 D)."""
    jam = jammed_spheres()
    cn = ContactNumber(c_min=4).compute(jam["frame"], jam["contacts"])
    rods = rsa_rods_2d(60, 3.0, 16.0, seed=3)
    c = geometric_contacts(rods, tolerance=0.1)
    types = contact_types(rods, c)
    ct = ContactTypes().compute(rods, c)
    fig, axs = plt.subplots(1, 2, figsize=(8.5, 3.6))
    k = np.arange(len(cn.distribution))
    axs[0].bar(k - 0.2, cn.distribution, width=0.4, label=f"all, <C> = {cn.z:.2f}")
    k2 = np.arange(len(cn.distribution_rattler_free))
    axs[0].bar(k2 + 0.2, cn.distribution_rattler_free, width=0.4,
               label=f"rattler-free, z = {cn.z_rattler_free:.2f}")
    axs[0].set(xlabel="contacts C", ylabel="P(C)",
               title=f"spheres at p = 1e-3 k_n/D: {cn.n_rattlers} rattlers")
    axs[0].legend(fontsize=8)
    for i in range(rods.n):
        stadium(axs[1], rods.x[i], rods.axis[i], 0.5, 3.0, color="0.8", ec="0.5", lw=0.5)
    for code, col in zip(range(3), ("C0", "C1", "C3")):
        sel = types == code
        axs[1].plot(c.point[sel, 0], c.point[sel, 1], "o", ms=4, color=col,
                    label=f"{TYPE_NAMES[code]} ({ct.counts[code]})")
    axs[1].set(xlim=(0, 16), ylim=(0, 16), aspect="equal", title="contact types (2-D rods)")
    axs[1].legend(fontsize=7, loc="upper right")
    save(fig, "contacts")


@figure
def fig_order():
    """S2, S4 versus alignment noise with the 1/sqrt(N) disorder level; f(beta) of
    isotropic and flattened 3-D rods; Q(r) of a noisy tetratic lattice."""
    rng = np.random.default_rng(4)
    n = 400
    widths = np.linspace(0, 1.5, 31)
    s2 = [order_parameter_2d(rng.normal(0, w, n), 2)[0] for w in widths]
    s4 = [order_parameter_2d(rng.normal(0, w, n), 4)[0] for w in widths]
    fig, axs = plt.subplots(1, 3, figsize=(11, 3.2))
    axs[0].plot(widths, s2, "o-", ms=3, label="S2")
    axs[0].plot(widths, s4, "s-", ms=3, label="S4")
    axs[0].plot(widths, np.exp(-2 * widths**2), "k:", lw=1, label="exp(-n^2 w^2 / 2)")
    axs[0].plot(widths, np.exp(-8 * widths**2), "k:", lw=1)
    axs[0].axhline(np.sqrt(np.pi) / 2 / np.sqrt(n), color="0.5", ls="--", label="sqrt(pi/4N)")
    axs[0].set(xlabel="angular noise w (rad)", ylabel="S_n", title=f"2-D order, N = {n}")
    axs[0].legend(fontsize=7)
    m = 20000
    u = rng.normal(size=(m, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    flat = u * [1, 1, 0.4]
    flat /= np.linalg.norm(flat, axis=1)[:, None]
    for vec, lab in ((u, "isotropic"), (flat, "flattened")):
        fr = Frame.from_arrays(np.zeros((m, 3)), 0.1, [10.0] * 3, axis=vec, length=1.0)
        a = AngleToHorizontal(bins=18).compute(fr)
        s = NematicOrder().compute(fr)
        axs[1].stairs(a.density, np.degrees(a.edges),
                      label=f"{lab}: <beta> = {a.mean_deg:.1f} deg, <P2> = {s.gravity_order:.2f}")
    b = np.linspace(0, np.pi / 2, 50)
    axs[1].plot(np.degrees(b), np.cos(b), "k:", lw=1, label="cos beta")
    axs[1].set(xlabel="angle to horizontal beta (deg)", ylabel="f(beta) (per rad)",
               title="orientation histogram")
    axs[1].legend(fontsize=7)
    g = np.array(np.meshgrid(np.arange(16), np.arange(16), indexing="ij")).reshape(2, -1).T
    theta = np.where(g.sum(1) % 2 == 0, 0.0, np.pi / 2) + rng.normal(0, 0.25, len(g))
    x = np.column_stack([g + 0.5, np.zeros(len(g))])
    fr = Frame.from_arrays(x, 0.1, [16.0, 16.0, 1.0], axis=np.column_stack(
        [np.cos(theta), np.sin(theta), np.zeros(len(g))]), length=0.6, dimension=2)
    qc = OrientationCorrelation(r_max=6.0, bins=60).compute(fr)
    o = OrientationOrder2D().compute(fr)
    ok = qc.counts > 0
    axs[2].plot(qc.centers[ok], qc.q[ok], "o", ms=4)
    axs[2].axhline(0, color="0.6", lw=0.5)
    axs[2].set(xlabel="centre distance r (lattice spacing 1)", ylabel="Q(r)",
               title=f"checkerboard: S2 = {o.S2:.2f}, S4 = {o.S4:.2f}")
    save(fig, "order")


@figure
def fig_stress():
    """Stress profile of a stack under gravity (with the floor's wall stress), and the
    distribution of the major principal axis in cubic elements of a jammed packing."""
    mg, layers = 1.0, 12
    g = np.array(np.meshgrid(np.arange(6), np.arange(6), np.arange(layers), indexing="ij")).reshape(3, -1).T
    x = g + 0.5
    fr = Frame.from_arrays(x, 0.5, [6.0, 6.0, 20.0], periodic=(True, True, False))
    floor = PlaneWall((0, 0, 0), (0, 0, 1))
    c = Contacts.concatenate([geometric_contacts(fr, 1e-9), wall_contacts(fr, floor, 1e-9)])
    top = layers - np.round(x[:, 2] - 0.5).astype(int)
    rows = fr.index_of(c.i)
    load = top[rows].astype(float)
    pp = np.isin(c.j, fr.ids)
    load[pp] = np.minimum(load[pp], top[fr.index_of(c.j[pp])])
    vertical = np.abs(c.normal[:, 2]) > 0.5
    f = np.zeros((c.n, 3))
    f[vertical] = -(load[vertical] * mg)[:, None] * c.normal[vertical]
    # lateral push K = 0.5 of the vertical load on horizontal bonds (a crude Janssen K)
    lateral = ~vertical & pp
    f[lateral] = -(0.5 * load[lateral] * mg)[:, None] * c.normal[lateral]
    c.force = f
    prof = StressProfile(thickness=1.0, top=float(layers)).compute(fr, c)
    jam = jammed_spheres()
    field = StressField(element=1.6, angle_bins=6).compute(jam["frame"], jam["contacts"])
    fig, axs = plt.subplots(1, 2, figsize=(8.5, 3.2))
    ok = prof.count > 0
    axs[0].plot(-prof.sigma_vv[ok], prof.depth[ok], "o-", ms=3, label="-sigma_zz")
    axs[0].plot(-prof.sigma_hh[ok], prof.depth[ok], "s-", ms=3, label="-sigma_xx,yy")
    axs[0].invert_yaxis()
    axs[0].set(xlabel="compressive stress (mg / D^2)", ylabel="depth below top (D)",
               title="slab profile (stack on a floor)")
    axs[0].legend(fontsize=8)
    e = field.angle_edges
    axs[1].stairs(field.angle_hist, np.degrees(e),
                  label=f"{np.isfinite(field.major_angle).sum()} elements")
    b = np.linspace(0, np.pi / 2, 50)
    axs[1].plot(np.degrees(b), np.cos(b), "k:", label="isotropic: cos")
    axs[1].set(xlabel="major axis elevation (deg)", ylabel="density (per rad)",
               title="jammed spheres: major axis in elements")
    axs[1].legend(fontsize=8)
    save(fig, "stress")


@figure
def fig_janssen():
    """A synthetic noisy profile and both Janssen fits with their uncertainties."""
    rng = np.random.default_rng(5)
    w = 10.0
    depth = np.linspace(0.5, 40, 40)
    y = janssen(depth / w, 100.0, 0.7) + rng.normal(0, 3.0, depth.size)
    fit = JanssenFit(width=w).compute(depth, y, sigma_err=3.0)
    cl = JanssenFit(form="classical", width=w, mu_w=0.5).compute(depth, y, sigma_err=3.0)
    fig, ax = plt.subplots(figsize=(5, 3.2))
    ax.errorbar(depth / w, y, yerr=3.0, fmt="o", ms=3, label="synthetic data")
    xx = np.linspace(0, 4, 200)
    ax.plot(xx, janssen(xx, fit.sigma_m, fit.h_s), "C3",
            label=f"sigma_m = {fit.sigma_m:.1f} +- {fit.sigma_m_err:.1f},\n"
                  f"h_s = {fit.h_s:.3f} +- {fit.h_s_err:.3f}")
    ax.plot([], [], " ", label=f"classical: lambda = {cl.h_s:.2f} +- {cl.h_s_err:.2f},\n"
                                f"K (mu_w = 0.5) = {cl.K:.2f} +- {cl.K_err:.2f}")
    ax.set(xlabel="depth / W", ylabel="sigma (compressive)", title="Janssen fits (truth 100, 0.7)")
    ax.legend(fontsize=7)
    save(fig, "janssen")


@figure
def fig_jamming():
    """Pressure versus packing fraction of the pysim compression and the fit."""
    jam = jammed_spheres()
    jp = jam["fit"]
    fig, ax = plt.subplots(figsize=(5, 3.2))
    ax.plot(jam["phi"], jam["p"] / 1e5, "o", ms=3, label="pysim, 300 spheres")
    sel = jam["phi"][jp.rows]
    ax.plot(sel, jp.slope / 1e5 * (sel - jp.phi_j), "C3", label="fit of the first rise")
    ax.axvline(jp.phi_j, color="k", ls="--",
               label=f"phi_J = {jp.phi_j:.4f} +- {jp.phi_j_err:.4f}")
    ax.set(xlabel="phi", ylabel="p D / k_n", ylim=(-0.0002, 0.003), xlim=(0.58, 0.66),
           title="jamming point (window 1e-4 ... 1e-3)")
    ax.legend(fontsize=8)
    save(fig, "jamming")


@figure
def fig_caging():
    """Caging number versus aspect ratio (200 trials per point)."""
    alphas = np.array([0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0])
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    for dim, axial, mk in ((3, False, "o"), (3, True, "s"), (2, False, "^"), (2, True, "v")):
        m, e = [], []
        for a in alphas:
            c = CagingNumber(radius=0.5, length=a, dim=dim, block_axial=axial, trials=200,
                             seed=1).compute()
            m.append(c.mean)
            e.append(c.stderr)
        ax.errorbar(alphas, m, yerr=e, marker=mk, ms=4, capsize=2,
                    label=f"{dim}-D" + (", axial blocked" if axial else ""))
    ax.axhline(7, color="0.6", ls=":", lw=1)
    ax.axhline(5, color="0.6", ls=":", lw=1)
    ax.set(xscale="symlog", xlabel="alpha = L / D", ylabel="caging number",
           title="random contacts until caged (alpha = 0: 7 and 5)")
    ax.set_xscale("symlog", linthresh=0.25)
    ax.set_xticks(alphas, [f"{a:g}" for a in alphas])
    ax.legend(fontsize=7)
    save(fig, "caging")


@figure
def fig_theory():
    """Random contact equation, its thin-rod limit and the aligned packing limit."""
    a = np.logspace(-1, 2, 200)
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    for c in (6.0, 10.0):
        ax.plot(a, theory.rce_packing_fraction(c, a), label=f"RCE, <C> = {c:g}")
        ax.plot(a, theory.thin_rod_limit(c, a), ":", color=ax.lines[-1].get_color(),
                label=f"thin rods: <C>/(2 alpha)")
    ax.plot(a, theory.aligned_phi_max(a), "k--", label="aligned phi_max")
    ax.set(xscale="log", yscale="log", ylim=(0.01, 1.2), xlabel="alpha = L / D",
           ylabel="phi", title="theory helpers")
    ax.legend(fontsize=7)
    save(fig, "theory")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", choices=sorted(FIGS), help="figures to make")
    args = ap.parse_args(argv)
    for name in args.only or sorted(FIGS):
        t0 = time.perf_counter()
        FIGS[name]()
        print(f"{name}.png: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
