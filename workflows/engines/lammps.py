"""LAMMPS (engine ``lammps``: spheres, glued-sphere rods, 2-D glued disks; engine
``lammps-body``: one body particle per rod): the ``-var`` values of its decks in
``inputs/lammps/``, what its decks cannot do, its command line, and the conversion of its
output to the common format. Which deck runs which case is the adapter table's
(:mod:`workflows.engines.table`)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pysim import io
from workflows.engines.common import (EngineError, _rod_vars, as_vars, compress_vars,
                                      glued_spheres, venv_bin)
from workflows.engines.convert import (_geometry, _iter_dump, _iter_local,
                                       _plane_wall_contacts, _with_walls, _write_converted,
                                       _write_glued_frame)
from workflows.engines.data import RHO_2D
from workflows.engines.restarts import _ke_peak


# -- -var values of the decks -----------------------------------------------------------------
def compress_spheres_vars(case: dict) -> dict[str, str]:
    """``-var`` values of ``in.spheres.compress``: :func:`~workflows.engines.common.
    compress_vars` with no tangential damping (``x_gamma_t = 0``)."""
    return as_vars({**compress_vars(case), "x_gamma_t": 0.0})


def compress_rods_vars(case: dict) -> dict[str, str]:
    """``-var`` values of ``in.rods.compress``: the compression's, the glued spheres per rod
    and ghost cutoff, and the tangential damping as a fraction of the normal one
    (``x_gamma_t = gamma_t / gamma_n``; friction acts between the glued spheres of
    different rods)."""
    c = case["contact"]
    v = {**compress_vars(case), **_rod_vars(case)}
    gamma_n = c.get("gamma_n", 0.0)
    v["x_gamma_t"] = c.get("gamma_t", 0.0) / gamma_n if gamma_n > 0 else 0.0
    return as_vars(v)


def body_rods_vars(case: dict) -> dict[str, str]:
    """``-var`` values of ``in.rods.body.compress`` (one body per rod, frictionless): the
    compression's without friction, and the largest diameter ``d_max``."""
    from rodcase.case import size_extremes

    v = compress_vars(case)
    for key in ("mu", "k_t"):
        v.pop(key)
    v["d_max"] = size_extremes(case["particles"]["diameter"])[2]
    return as_vars(v)


def tap_deck_vars(case: dict) -> dict[str, str]:
    """``-var`` values of the tapping deck (``in.rods.tap``) for a case: the same step
    plan as pysim's (:func:`pysim.protocols.tapping.plan`)."""
    from pysim.protocols.tapping import plan, settle_drag

    c, pr = case["contact"], case["protocol"]
    tp = plan(pr, case["gravity"])
    gamma_n = c.get("gamma_n", 0.0)
    v = {"k_n": c["k_n"], "gamma_n": gamma_n, "k_t": c.get("k_t", 0.0),
         "x_gamma_t": c.get("gamma_t", 0.0) / gamma_n if gamma_n > 0 else 0.0,
         "mu": c.get("friction", 0.0), "mu_wall": c.get("wall_friction", c.get("friction", 0.0)),
         "g": case["gravity"], "radius_c": 0.5 * case["container"]["diameter"], "dt": pr["dt"],
         "drag": settle_drag(case)[0], "settle_steps": tp.settle_steps,
         "relax_steps": tp.start - tp.settle_steps, "freq": 1.0 / tp.period,
         "amp": tp.amplitude, "taps": pr["taps"], "frames_per_tap": tp.frames_per_tap,
         "thermo_every": case.get("output", {}).get("thermo_every", 1000), **_rod_vars(case)}
    # a column landing after a tap throws single rods off fast: with the compression
    # decks' 0.2 D skin, 1000 rods moved half the skin within a step (LAMMPS' 'dangerous
    # builds'); 0.4 D covers twice that speed, and the ghost cutoff grows with it
    d = case["particles"]["diameter"]["mean"]
    v["skin"] = 0.4 * d
    v["ghost_cut"] += 0.2 * d
    return {k: repr(float(x)) if isinstance(x, float) else str(x) for k, x in v.items()}


def deposit_deck_vars(case: dict) -> dict[str, str]:
    """``-var`` values of the deposition deck (``in.rods.deposit``): pysim's Hertz
    stiffness (the deck converts it to LAMMPS' ``k_N = k_n / sqrt(R_eff)``), the cohesive
    force ``F_c = Bo_g m g`` per sphere pair within ``d_c``, and the settling test of
    :mod:`pysim.protocols.deposit` at every ``thermo.dat`` row."""
    from pysim.protocols.deposit import cohesion, rain_drag, rain_steps

    c, pr = case["contact"], case["protocol"]
    out = case.get("output", {})
    gamma_n = c.get("gamma_n", 0.0)
    f_c, d_c = cohesion(case)
    every = out.get("thermo_every", 1000)
    dt = pr["dt"]
    rain_end = rain_steps(pr)
    d = case["particles"]["diameter"]["mean"]
    v = {"width": case["container"]["width"], "k_n": c["k_n"], "gamma_n": gamma_n,
         "k_t": c.get("k_t", 0.0),
         "x_gamma_t": c.get("gamma_t", 0.0) / gamma_n if gamma_n > 0 else 0.0,
         "mu": c.get("friction", 0.0), "mu_wall": c.get("wall_friction", c.get("friction", 0.0)),
         "f_coh": f_c, "d_coh": d_c, "g": case["gravity"], "dt": dt,
         "check_every": every, "thermo_every": every,
         "min_steps": max(int(np.ceil(pr.get("min_time", 0.0) / dt)), rain_end),
         "max_steps": int(np.ceil(pr["max_time"] / dt)),
         "settle_ratio": pr.get("ke_ratio", 1e-6), "dump_every": out.get("dump_every", 4000),
         "drag": rain_drag(case)[0], "rain_steps": rain_end,
         "skin": 0.2 * d, **_rod_vars(case)}
    if case["particles"]["diameter"].get("distribution", "mono") != "mono":
        raise EngineError("the LAMMPS deposition deck needs equal spheres (mono diameters)")
    return {k: repr(float(x)) if isinstance(x, float) else str(x) for k, x in v.items()}


def deposit_2d_vars(case: dict) -> dict[str, str]:
    """``-var`` values of the 2-D fed deposit deck (``in.2d.rods.deposit``): the grains'
    size, disks and areal density, the feed's entry line and grain count (the entries
    themselves are in the feed file, :mod:`workflows.engines.feed`), the law and settling
    test of :func:`deposit_deck_vars`, with pysim's fed settling: no check passes before
    the last grain's entry step, and ``max_steps`` is rounded up to a ``thermo.dat`` row."""
    from pysim.protocols.deposit import entry_step

    p, pr = case["particles"], case["protocol"]
    v = {k: x for k, x in deposit_deck_vars(case).items()
         if k not in ("spheres", "drag", "rain_steps")}
    d = p["diameter"]["mean"]
    length = p["aspect_ratio"] * d
    every = int(v["thermo_every"])
    max_steps = int(v["max_steps"])
    v.update(grains=str(p["n"]), height=repr(float(pr["feed"]["height"])),
             diameter=repr(float(d)), length=repr(float(length)),
             rho=repr(float(p.get("density", 1.0))),
             disks=str(glued_spheres(length, d, p.get("glued_spacing", 0.25))),
             min_steps=str(max(int(v["min_steps"]), entry_step(p["n"] - 1, pr))),
             max_steps=str(-(-max_steps // every) * every))
    return v


def fed_2d_deposit(engine: str, case: dict) -> str | None:
    """The 2-D deposit deck feeds grains (``protocol.feed``; no raining column), replays
    pysim's entries in free flight (no background drag), and needs 3 or more disks per rod
    whose end and inner masses give the stadium's mass and inertia."""
    from workflows.engines.feed import check_feed_case

    why = check_feed_case(case)
    if why:
        return f"the LAMMPS 2-D deposit deck: {why}"
    p = case["particles"]
    if p["diameter"].get("distribution", "mono") != "mono":
        return ("the LAMMPS 2-D deposit deck needs equal grains (particles.diameter."
                f"distribution mono, got {p['diameter']['distribution']})")
    d = p["diameter"]["mean"]
    length = p["aspect_ratio"] * d
    n = glued_spheres(length, d, p.get("glued_spacing", 0.25))
    if disk_masses(d, length, n, 1.0) is None:
        return (f"the LAMMPS 2-D deposit deck cannot give {n} disks (aspect ratio "
                f"{p['aspect_ratio']}, glued_spacing {p.get('glued_spacing', 0.25)}) the "
                "stadium's mass and inertia with positive masses; use a smaller glued_spacing")
    return None


def disk_masses(diameter: float, length: float, disks: int, density: float):
    """``(m_end, m_inner)``: the masses of the end disks and of each inner disk of a rod of
    ``disks`` equal disks along a spine of ``length`` that give it the stadium's mass
    ``rho (D L + pi D^2/4)`` and moment of inertia (:func:`pysim.state.inertia_2d`), with
    each disk's own ``2/5 m R^2`` as fix rigid/small counts it (the formulas of
    ``in.2d.rods.deposit``'s header; mass units); ``None`` when no positive pair exists."""
    from pysim.state import area, inertia_2d

    if disks < 3:
        return None
    r = 0.5 * diameter
    m = density * float(area(r, length))
    inertia = float(inertia_2d(r, length, density))
    s = np.linspace(-0.5 * length, 0.5 * length, disks)[1:-1]
    s_bar = float(np.mean(s * s))
    m_end = (inertia - 0.4 * r * r * m - m * s_bar) / (0.5 * length**2 - 2.0 * s_bar)
    m_in = (m - 2.0 * m_end) / (disks - 2)
    return (m_end, m_in) if m_end > 0 and m_in > 0 else None


def deck_vars_2d(case: dict) -> dict[str, str]:
    """``-var`` values of ``in.2d.compress`` (see its header): the harmonic law, the drag
    per area, the two radii, disks per rod and the stages of the overdamped protocol."""
    from rodcase.case import particle_measure, size_extremes

    p, c, pr = case["particles"], case["contact"], case["protocol"]
    out = case.get("output", {})
    alpha = p["aspect_ratio"]
    d_small, _, d_big = size_extremes(p["diameter"])
    disks = glued_spheres(alpha * d_small, d_small, p.get("glued_spacing", 0.25))
    a_small = particle_measure(d_small, alpha, 2)
    v = {"k_e": c["k_n"], "k_d": pr.get("k_d", 1.0), "r_small": d_small / 2, "r_big": d_big / 2,
         "a_small": a_small, "a_big": particle_measure(d_big, alpha, 2), "disks": disks,
         "rho_disk": RHO_2D * a_small / (disks * np.pi * d_small**2 / 4), "dt": pr["dt"],
         "phi_init": pr["phi_init"], "phi_final": pr["phi_final"], "rate": pr["rate"],
         "phi_fast": pr.get("phi_fast", pr["phi_init"]), "rate_fast": pr.get("rate_fast", 1.0),
         "thermo_every": out.get("thermo_every", 1000), "dump_every": out.get("dump_every", 4000),
         "ghost_cut": (alpha + 1.0) * d_big + 0.2 * d_big}
    return {k: repr(float(x)) if isinstance(x, float) else str(x) for k, x in v.items()}


def body_2d_vars(case: dict) -> dict[str, str]:
    """``-var`` values of ``in.2d.body.compress``: those of :func:`deck_vars_2d` less the
    glued disks (one body per rod: no disks, no ghost cutoff) and with the smallest rod's
    mass ``m_small = RHO_2D a_small``."""
    v = deck_vars_2d(case)
    for key in ("disks", "rho_disk", "ghost_cut"):
        v.pop(key)
    v["m_small"] = repr(RHO_2D * float(v["a_small"]))
    return v


def clip_vars(case: dict) -> dict[str, str]:
    """``contact.limit_damping`` as the 3-D glued decks take it: ``-var limit_damping 1``
    (LAMMPS' ``limit_damping`` keyword on the pair style and the walls); nothing when it is
    off."""
    return {"limit_damping": "1"} if case["contact"].get("limit_damping", False) else {}


def deposit_resume_vars(work: Path, step: int) -> dict[str, str]:
    """What the deposition deck needs to resume at ``step``: the running peak of the
    kinetic energy its settling test divides by."""
    return {"ke_peak": repr(_ke_peak(work / "screen.txt", step))}


# -- what the decks cannot do ------------------------------------------------------------------
def no_limit_damping(engine: str, case: dict) -> str | None:
    """LAMMPS' body pair styles have no damping clip."""
    if case["contact"].get("limit_damping", False):
        return ("contact.limit_damping: LAMMPS' body pair styles have no limit_damping "
                "option; use engine 'lammps' (glued rods) or pysim")
    return None


def harmonic_2d_only(engine: str, case: dict) -> str | None:
    """The 2-D decks implement the frictionless soft harmonic law (overdamped dynamics:
    emulated by strong drag against the deforming box)."""
    c = case["contact"]
    if c["law"] != "harmonic" or c.get("friction", 0.0) > 0:
        return ("the LAMMPS 2-D deck implements the frictionless soft harmonic law only "
                f"(got law {c['law']})")
    return None


def body_rods_law(engine: str, case: dict) -> str | None:
    """The 3-D body deck implements the frictionless linear law and stops at ``phi_final``."""
    c = case["contact"]
    if c["law"] != "hooke" or c.get("friction", 0.0) > 0:
        return ("the lammps-body 3-D deck implements the frictionless linear law only "
                f"(got law {c['law']}, friction {c.get('friction', 0.0)})")
    if "pressure_final" in case["protocol"]:
        return "the lammps-body 3-D deck has no pressure_final stop"
    return None


# -- running -----------------------------------------------------------------------------------
#: the version line LAMMPS prints first (``LAMMPS (22 Jul 2025 - Update 4)``)
VERSION = r"^(LAMMPS \(.*\))"


def command(deck: Path, outdir: Path, ranks: int, args: list[str]) -> list[str]:
    """``lmp -in deck -log outdir/log.lammps args`` from this environment, under
    ``mpiexec -n ranks`` when ``ranks > 1``."""
    exe = [venv_bin("lmp")]
    if ranks > 1:
        exe = [venv_bin("mpiexec"), "-n", str(ranks)] + exe
    return exe + ["-in", str(deck), "-log", str(outdir / "log.lammps")] + args


# -- output -> common format -------------------------------------------------------------------
def convert_spheres(work: Path, case: dict, data: Path) -> dict:
    """The spheres deck's ``contacts.native`` -> ``contacts.dump`` in ``work``
    (:func:`convert_lammps_contacts`)."""
    return convert_lammps_contacts(work / "contacts.native", work / "particles.dump",
                                   work / "contacts.dump")


def convert_glued(work: Path, case: dict, data: Path) -> dict:
    """The glued decks' spheres and contacts in ``work`` -> rods (``particles.dump``) and
    rod contacts (``contacts.dump``) (:func:`convert_glued_rods`; the container's width
    tells the deposition walls apart)."""
    width = case.get("container", {}).get("width")
    stats = convert_glued_rods(work / "contacts.native", work / "particles.dump",
                               work / "contacts.dump", work / "rods.dump",
                               None if width is None else float(width))
    os.replace(work / "rods.dump", work / "particles.dump")
    return stats


def convert_bodies(work: Path, case: dict, data: Path) -> dict:
    """The body decks' centres and spine ends in ``work`` -> rods and geometric contacts
    with forces from the closest-point law (:func:`convert_body_rods`: harmonic in 2-D,
    linear in 3-D)."""
    two_d = case["particles"].get("dimension", 3) == 2
    law = ("harmonic" if two_d else "hooke", float(case["contact"]["k_n"]))
    stats = convert_body_rods(work / "vertices.native", work / "particles.dump", data, law,
                              work / "contacts.dump", work / "rods.dump", 2 if two_d else 3)
    os.replace(work / "rods.dump", work / "particles.dump")
    return stats


#: LAMMPS deposition walls (fix wall/gran ... contacts, dumped as f_<fix>[1..7]), in pysim's
#: order of wall ids -(k + 1): (fix id, axis, at the far side x = W)
GLUED_WALLS = (("wallx", 0, False), ("wallx", 0, True), ("wally", 1, False), ("wally", 1, True),
               ("base", 2, False))
#: the same in 2-D (in.2d.rods.deposit: no y walls, the base at y = 0)
GLUED_WALLS_2D = (("wallx", 0, False), ("wallx", 0, True), ("base", 1, False))


def glued_wall_contacts(frame, table, cols, width: float):
    """Sphere-wall contacts of the LAMMPS deposition deck from its wall fixes' per-atom
    contact arrays (``fix wall/gran ... contacts``: ``f_<fix>[1]`` 1 in contact,
    ``[2..4]`` the wall's force on the sphere, ``[5..7]`` the contact's point on the wall;
    rows of ``table`` in ``frame`` order): one row per touching sphere and wall, ``j`` the
    wall id of :data:`GLUED_WALLS` (pysim's numbering: x = 0, x = W, y = 0, y = W, base;
    2-D, without ``f_wally`` columns: :data:`GLUED_WALLS_2D`, x = 0, x = W, base;
    the fix ``wallx`` holds both x walls, told apart by the point), normal from the sphere
    to the wall, overlap ``R - distance``, point in the middle of the overlap. Returns a
    :class:`analysis.frame.Contacts`."""
    c = {name: k for k, name in enumerate(cols)}
    walls = []
    for fix, axis, far in GLUED_WALLS if "f_wally[1]" in c else GLUED_WALLS_2D:
        flag = table[:, c[f"f_{fix}[1]"]]
        force = table[:, [c[f"f_{fix}[{k}]"] for k in (2, 3, 4)]]
        wall = table[:, [c[f"f_{fix}[{k}]"] for k in (5, 6, 7)]]
        on = np.flatnonzero((flag > 0) & ((wall[:, axis] > 0.5 * width) == far))
        walls.append((on, axis, far, np.abs(wall[on, axis] - frame.x[on, axis]), force[on]))
    return _plane_wall_contacts(frame, walls)


def convert_glued_rods(native: Path, particles: Path, out_contacts: Path, out_particles: Path,
                       width: float | None = None):
    """Glued-sphere output of the LAMMPS rods deck -> rods in the common format.

    Each frame of spheres (``id mol type x y z radius``) becomes a frame of
    spherocylinders (:func:`analysis.contacts.glued_bodies`: centre, axis, spine length
    from the sphere centres, id = molecule id); the sphere contacts of two rods merge into
    one rod-rod contact (:func:`analysis.contacts.merge_glued_contacts`: summed force,
    force-weighted point, deepest overlap). When the dump has the deposition deck's wall
    columns (``f_base[1]`` ...; ``width`` the container's), the sphere-wall contacts
    (:func:`glued_wall_contacts`) merge per rod and wall as well.
    """
    from analysis.frame import Contacts
    from analysis.io import read_particle_frames

    spheres = {f.step: f for f in read_particle_frames(particles)}
    mol, walls = {}, {}
    for step, _b, _p, cols, table in _iter_dump(particles):
        c = {name: k for k, name in enumerate(cols)}
        order = np.argsort(table[:, c["id"]], kind="stable")
        mol[step] = table[order, c["mol"]].astype(np.int64)
        if "f_base[1]" in c:
            if width is None:
                raise EngineError(f"{particles} has wall contact columns: give the container "
                                  "width to tell its walls apart")
            walls[step] = glued_wall_contacts(spheres[step], table[order], cols, width)
    dropped = 0
    with open(io.part_path(out_contacts), "w") as fc, open(io.part_path(out_particles), "w") as fp:
        for step, _box, cols, table in _iter_local(native):
            fr = spheres[step]
            ids_i, ids_j = table[:, 0], table[:, 1]
            n, delta, point = _geometry(fr, ids_i, ids_j)
            keep = delta > 0
            dropped += int(np.count_nonzero(~keep))
            sph = Contacts(step, ids_i[keep].astype(np.int64), ids_j[keep].astype(np.int64),
                           point[keep], n[keep], delta[keep], (table[:, 3:6] + table[:, 6:9])[keep])
            if step in walls:
                sph = _with_walls(sph, walls[step])
            _write_glued_frame(fp, fc, fr, sph, mol[step])
    io.finalize(out_contacts)
    io.finalize(out_particles)
    return {"dropped": dropped}


def convert_lammps_contacts(native: Path, particles: Path, out: Path) -> dict:
    """LAMMPS ``patom1 patom2 dist fx fy fz p1 p2 p3 p10 p11 p12`` -> common table.

    The force on i is the normal part ``(fx, fy, fz)`` plus the tangential part
    ``(p1, p2, p3)`` of pair granular (its documented single() extras).
    """
    def columns_of(cols, t):
        return t[:, 0], t[:, 1], t[:, 3:6] + t[:, 6:9]

    return _write_converted(native, particles, out, columns_of)


def convert_body_rods(vertices: Path, particles: Path, data: Path, law: tuple,
                      out_contacts: Path, out_particles: Path, dimension: int) -> dict:
    """Output of the LAMMPS body decks -> rods and contacts in the common format.

    Each frame's body centres (``particles.dump``) and spine ends (``vertices.native``,
    ``compute body/local``) become spherocylinders (axis and length from the two ends,
    radius from the initial data). LAMMPS' body pair styles have no per-contact output,
    so the contact table is geometric (:func:`analysis.contacts.geometric_contacts`) and
    its forces are *reconstructed* from the overlaps with the closest-point law
    ``law``: ``("harmonic", k_e)`` for ``F = k_e delta / d_ij^2`` (``d_ij = R_i + R_j``)
    or ``("hooke", k_n)`` for ``F = k_n delta`` (elastic part only): the pressure in
    ``thermo.dat`` is LAMMPS' own virial, the contact forces are not.
    """
    from analysis.contacts import geometric_contacts
    from analysis.frame import Frame
    from pysim.io import read_particle_data

    init = read_particle_data(data)
    radius_of = {int(t): float(r) for t, r in zip(init["ids"], init["radius"])}
    ends = {}
    for step, _box, cols, table in _iter_local(vertices):
        c = {name: k for k, name in enumerate(cols)}
        ids = table[:, c["c_ends[1]"]].astype(np.int64)
        xyz = table[:, [c["c_ends[2]"], c["c_ends[3]"], c["c_ends[4]"]]]
        ends[step] = (ids, xyz)
    with open(io.part_path(out_contacts), "w") as fc, open(io.part_path(out_particles), "w") as fp:
        for step, bounds, periodic, cols, table in _iter_dump(particles):
            if step not in ends:
                raise EngineError(f"{vertices}: no spine ends at step {step} of {particles}")
            c = {name: k for k, name in enumerate(cols)}
            order = np.argsort(table[:, c["id"]], kind="stable")
            ids = table[order, c["id"]].astype(np.int64)
            x = table[order][:, [c["x"], c["y"], c["z"]]]
            vid, vxyz = ends[step]
            first, last = {}, {}
            for k, t in enumerate(vid):
                (last if int(t) in first else first)[int(t)] = vxyz[k]
            axis = np.tile([1.0, 0.0, 0.0], (len(ids), 1))
            length = np.zeros(len(ids))
            for k, t in enumerate(ids):
                if int(t) in last:
                    seg = last[int(t)] - first[int(t)]
                    length[k] = float(np.linalg.norm(seg))
                    axis[k] = seg / length[k]
            radius = np.array([radius_of[int(t)] for t in ids])
            lo, box = bounds[:, 0], bounds[:, 1] - bounds[:, 0]
            fr = Frame(step=step, ids=ids, types=table[order, c["type"]].astype(np.int64),
                       x=x, radius=radius, axis=axis, length=length, box_lo=lo, box=box,
                       periodic=np.asarray(periodic, dtype=bool), dimension=dimension)
            con = geometric_contacts(fr)
            index = {int(t): k for k, t in enumerate(ids)}
            a = np.array([index[int(t)] for t in con.i], dtype=np.int64)
            b = np.array([index[int(t)] for t in con.j], dtype=np.int64)
            kind_of_law, k = law
            if kind_of_law == "harmonic":
                stiffness = k / (radius[a] + radius[b]) ** 2
            else:
                stiffness = np.full(len(a), float(k))
            force = -(stiffness * con.overlap)[:, None] * con.normal
            io.write_particles_frame(fp, step, box, fr.periodic, ids, fr.types, x, radius,
                                     axis=axis, length=length, box_lo=lo)
            rec = np.column_stack([con.point, con.normal, con.overlap, force])
            io.write_contacts_frame(fc, step, box, fr.periodic, np.column_stack([con.i, con.j]),
                                    rec, box_lo=lo)
    io.finalize(out_contacts)
    io.finalize(out_particles)
    return {"dropped": 0}
