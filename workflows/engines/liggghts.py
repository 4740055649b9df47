"""LIGGGHTS (engine ``liggghts``: spheres read from ``init.data``; rods as multisphere
bodies that its decks insert themselves): the ``-var`` values of its decks in
``inputs/liggghts/``, what they cannot do, its command line, its restart files (tapping)
and the conversion of its output to the common format. Which deck runs which case is the
adapter table's (:mod:`workflows.engines.table`)."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np

from pysim import io
from workflows.engines.common import (EngineError, _insertion_seed, as_vars, compress_vars,
                                      glued_spheres)
from workflows.engines.convert import (_geometry, _iter_dump, _iter_local, _with_walls,
                                       _write_converted, _write_glued_frame,
                                       _plane_wall_contacts)
from workflows.engines.restarts import _newest_complete


# -- spheres: compression (inputs/liggghts/in.spheres.compress) --------------------------------
def compress_spheres_vars(case: dict) -> dict[str, str]:
    """``-var`` values of ``in.spheres.compress``: :func:`~workflows.engines.common.
    compress_vars` and the absolute tangential damping ``gamma_t``."""
    return as_vars({**compress_vars(case), "gamma_t": case["contact"].get("gamma_t", 0.0)})


def clip_vars(case: dict) -> dict[str, str]:
    """``contact.limit_damping`` as the decks take it: ``-var limit_force on``
    (``limitForce``); nothing when it is off."""
    return {"limit_force": "on"} if case["contact"].get("limit_damping", False) else {}


def restore_box_precision(particles: Path, box_file: Path, data: Path):
    """Rewrite the box bounds of a LIGGGHTS particle dump at full precision.

    LIGGGHTS prints dump box bounds with 6 significant digits; its deck prints them in
    full to ``box.dat`` at the dump steps (``fix print`` runs from the first dump
    interval on), and the data file gives the box at step 0.
    """
    from pysim.io import read_particle_data

    bounds = {}
    init = read_particle_data(data)
    bounds[0] = np.column_stack([init["box_lo"], init["box_lo"] + init["box"]])
    with open(box_file) as fh:
        for line in fh:
            if line.strip() and not line.startswith("#"):
                v = line.split()
                bounds[int(float(v[0]))] = np.array(v[1:7], dtype=np.float64).reshape(3, 2)
    lines = particles.read_text().splitlines()
    k = 0
    while k < len(lines):
        if lines[k].startswith("ITEM: TIMESTEP"):
            step = int(lines[k + 1])
            if step not in bounds:
                raise EngineError(f"{box_file}: no box bounds for dump step {step}")
            for a in range(3):
                lines[k + 5 + a] = f"{bounds[step][a, 0]:.16g} {bounds[step][a, 1]:.16g}"
            k += 9 + int(lines[k + 3])
        else:
            k += 1
    tmp = io.part_path(particles)
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, particles)


def convert_liggghts_contacts(native: Path, particles: Path, out: Path) -> dict:
    """LIGGGHTS ``pos(6) id_i id_j periodic force(3) delta`` -> common table.

    ``force`` is the total contact force on i. Contact points are recomputed from the
    particle frame because LIGGGHTS' own ``contactPoint`` is wrong across periodic
    boundaries.
    """
    def columns_of(cols, t):
        return t[:, 6], t[:, 7], t[:, 9:12]

    return _write_converted(native, particles, out, columns_of)


def convert_spheres(work: Path, case: dict, data: Path) -> dict:
    """The spheres deck's output in ``work`` -> full-precision box bounds
    (:func:`restore_box_precision`) and ``contacts.dump`` (:func:`convert_liggghts_contacts`)."""
    restore_box_precision(work / "particles.dump", work / "box.dat", data)
    return convert_liggghts_contacts(work / "contacts.native", work / "particles.dump",
                                     work / "contacts.dump")


# -- LIGGGHTS deposition: multisphere rods (inputs/liggghts/in.rods.deposit) ---------------------
#: the smallest restitution coefficient passed to LIGGGHTS: it refuses 0.05 and below
#: ("0.05 < coefficientRestitution <= 1 required"), while pysim's law with a constant
#: gamma_n stops rebounding altogether below some impact speed (rods of d = 2 in the quick
#: deposition profile: e = 0 for a rod pair)
E_MIN = 0.06


#: how full LIGGGHTS' insertion may make the column its rods' centres can use (rod volume
#: over that column's volume): fix insert/pack keeps a rod's bounding sphere (diameter
#: L + D) inside the region, so the centres of rods of d = 5 in a box of width 8 D share a
#: 3 D x 3 D column; measured: 84 of 150 such rods placed at 0.80, all 150 at 0.72
PHI_INSERT = 0.6


def liggghts_deposit_support(case: dict) -> str | None:
    """``None`` when ``in.rods.deposit`` of LIGGGHTS can run a (3-D rod) deposition case,
    else the reason."""
    p, c = case["particles"], case["contact"]
    if p["diameter"].get("distribution", "mono") != "mono":
        return "the LIGGGHTS deposition deck has one rod template: equal diameters (mono) only"
    if c["law"] != "hertz":
        return (f"the LIGGGHTS deposition deck maps pysim's Hertz law only (got law "
                f"{c['law']})")
    if "rain_speed" in case["protocol"]:
        return "the LIGGGHTS deposition deck has no rain drag (protocol.rain_speed)"

    d = p["diameter"]["mean"]
    if not case["container"]["width"] > (1.0 + p["aspect_ratio"]) * d:
        return ("LIGGGHTS inserts a rod only where its bounding sphere (diameter L + D) fits "
                "between the walls: the box width must exceed L + D")
    return None


def hertz_restitution(k_n: float, gamma_n: float, m_eff: float, v: float) -> float:
    """Restitution coefficient of pysim's normal law ``f = k_n delta^(3/2) + gamma_n
    d(delta)/dt`` (damping not clipped, as pysim) in a head-on collision of effective mass
    ``m_eff`` at impact speed ``v``: minus the overlap rate when the overlap returns to zero,
    over ``v``; 0 when it does not return within 50 undamped contact times."""
    from scipy.integrate import solve_ivp

    if gamma_n <= 0:
        return 1.0

    def rhs(_t, y):
        return [y[1], -(k_n * max(y[0], 0.0) ** 1.5 + gamma_n * y[1]) / m_eff]

    def leaves(_t, y):
        return y[0]

    leaves.terminal, leaves.direction = True, -1
    t_c = 3.2 * (m_eff**2 / (k_n**2 * v)) ** 0.2  # undamped Hertz contact time (2.94...)
    sol = solve_ivp(rhs, [0.0, 50.0 * t_c], [0.0, v], events=leaves, rtol=1e-10, atol=1e-14,
                    max_step=t_c / 200.0)
    if sol.t_events[0].size == 0:
        return 0.0
    return float(-sol.y_events[0][0][1] / v)


def liggghts_column_height(case: dict) -> float:
    """Height of the column LIGGGHTS inserts the rods into: pysim's column (packing
    fraction ``phi_init``, :func:`pysim.initial.random_spherocylinders_in_box`) for the rod
    centres, raised where fix insert/pack cannot place them that densely
    (:data:`PHI_INSERT`), plus one bounding-sphere diameter ``L + D``."""
    from pysim.protocols.deposit import grain_mass

    p = case["particles"]
    d = p["diameter"]["mean"]
    length = p["aspect_ratio"] * d
    w = case["container"]["width"]
    n = p["n"]
    volume = grain_mass(case) / p.get("density", 1.0)
    reach = length + d  # bounding-sphere diameter
    column = max(n * volume / (case["protocol"]["phi_init"] * w * w), reach)
    centres = (w - reach) ** 2  # area the bounding spheres' centres can use
    return max(column, n * volume / (PHI_INSERT * centres)) + reach


def liggghts_deposit_vars(case: dict) -> dict[str, str]:
    """``-var`` values of LIGGGHTS' deposition deck (``inputs/liggghts/in.rods.deposit``).

    The rods are multisphere templates of :func:`glued_spheres` spheres with the mass and
    inertia of the solid spherocylinder; the deck maps pysim's contact law to LIGGGHTS'
    material constants (see its header):

    * Hertz stiffness ``k_n`` (``f = k_n delta^(3/2)``): exact, through Young's moduli of
      grains and walls computed in the deck (``4/3 Y* sqrt(R*) = k_n`` for sphere-sphere and
      sphere-wall contacts, Poisson ratio 0);
    * damping: not matched (LIGGGHTS' Hertz damping gives a speed-independent restitution,
      pysim's constant ``gamma_n`` one that falls with the speed): ``e_n`` and ``e_wall``
      are pysim's restitution (:func:`hertz_restitution`) of a head-on rod-rod
      (``m_eff = m/2``) and rod-wall (``m_eff = m``) collision at the reference speed
      ``sqrt(g h)``, ``h`` the insertion column's height (:func:`liggghts_column_height`),
      floored at :data:`E_MIN`;
    * tangential spring: not matched (LIGGGHTS: Mindlin stiffness from the Poisson ratio,
      not pysim's ``k_t``, ``gamma_t``); friction ``mu`` and ``mu_wall`` as pysim's;
    * cohesion ``F_c = Bo_g m g`` (:func:`pysim.protocols.deposit.cohesion`), approximate:
      the deck sets sjkr's ``cohesionEnergyDensity`` so that the largest tensile force of a
      sphere-sphere contact is ``F_c`` (sjkr acts only on overlapping spheres, in
      proportion to the contact area; no range ``d_c``, no cohesion with the walls).

    The rods are inserted at random (not pysim's start), with Gaussian velocities of rms
    speed ``v_init``; the settling test is pysim's (:mod:`pysim.protocols.deposit`).
    """
    from pysim.protocols.deposit import cohesion, grain_mass

    p, c, pr = case["particles"], case["contact"], case["protocol"]
    reason = liggghts_deposit_support(case)
    if reason:
        raise EngineError(reason)
    out = case.get("output", {})
    d = p["diameter"]["mean"]
    length = p["aspect_ratio"] * d
    height = liggghts_column_height(case)
    m = grain_mass(case)
    v_ref = float(np.sqrt(case["gravity"] * height))
    gamma_n = c.get("gamma_n", 0.0)
    e_n = max(hertz_restitution(c["k_n"], gamma_n, m / 2, v_ref), E_MIN)
    e_wall = max(hertz_restitution(c["k_n"], gamma_n, m, v_ref), E_MIN)
    f_c, _d_c = cohesion(case)
    every = out.get("thermo_every", 1000)
    dt = pr["dt"]
    v = {"width": case["container"]["width"], "height": height, "n_rods": p["n"],
         "radius": d / 2, "length": length,
         "spheres": glued_spheres(length, d, p.get("glued_spacing", 0.25)),
         "density": p.get("density", 1.0), "k_n": c["k_n"], "e_n": e_n, "e_wall": e_wall,
         "mu": c.get("friction", 0.0), "mu_wall": c.get("wall_friction", c.get("friction", 0.0)),
         "f_coh": f_c, "g": case["gravity"], "v_init": pr.get("v_init", 0.0),
         "seed": _insertion_seed(case.get("seed", 1)), "dt": dt,
         "check_every": every, "thermo_every": every,
         "min_steps": int(np.ceil(pr.get("min_time", 0.0) / dt)),
         "max_steps": int(np.ceil(pr["max_time"] / dt)),
         "settle_ratio": pr.get("ke_ratio", 1e-6), "dump_every": out.get("dump_every", 4000),
         "skin": 0.2 * d}
    return {k: repr(float(x)) if isinstance(x, float) else str(x) for k, x in v.items()}


#: LIGGGHTS deposition walls as the deck names them (fix wall/gran ... store_force yes), in
#: pysim's order (wall id -(k + 1)): (fix id, axis, at the far side x = W)
MULTISPHERE_WALLS = (("wx0", 0, False), ("wx1", 0, True), ("wy0", 1, False), ("wy1", 1, True),
                     ("wz0", 2, False))


def multisphere_wall_contacts(frame, table, cols, width: float):
    """Sphere-wall contacts of LIGGGHTS' deposition deck from the wall forces it stores on
    each sphere (``f_force_<wall>[1..3]`` columns of the sphere dump, rows in ``frame``
    order): one row per sphere and wall with a nonzero force, ``j`` the wall id of
    :data:`MULTISPHERE_WALLS` (pysim's numbering: x = 0, x = W, y = 0, y = W, base), normal
    from the sphere to the wall, overlap ``R - distance``, point in the middle of the
    overlap, force on the sphere. Returns a :class:`analysis.frame.Contacts`."""
    c = {name: k for k, name in enumerate(cols)}
    walls = []
    for fix, axis, far in MULTISPHERE_WALLS:
        force = table[:, [c[f"f_force_{fix}[{k}]"] for k in (1, 2, 3)]]
        on = np.flatnonzero(np.any(force != 0.0, axis=1))
        gap = (width - frame.x[on, axis]) if far else frame.x[on, axis]
        walls.append((on, axis, far, gap, force[on]))
    return _plane_wall_contacts(frame, walls)


def convert_multisphere_rods(native: Path, particles: Path, out_contacts: Path,
                             out_particles: Path, width: float) -> dict:
    """Output of LIGGGHTS' deposition deck (multisphere rods) -> rods and contacts in the
    common format.

    The sphere dump (``id id_multisphere type x y z radius f_force_<wall>[1..3]``) becomes
    rods as the LAMMPS glued rods do (:func:`analysis.contacts.glued_bodies` with the body
    id ``id_multisphere``: centre, axis from the sphere centres, spine length, id = body
    id); the sphere-sphere contacts (``compute pair/gran/local pos id force delta``,
    geometry recomputed from the frame) and the sphere-wall contacts
    (:func:`multisphere_wall_contacts`) merge per rod pair and per rod and wall
    (:func:`analysis.contacts.merge_glued_contacts`).
    """
    return _convert_multisphere(
        native, particles, out_contacts, out_particles,
        lambda fr, table, cols, _step: multisphere_wall_contacts(fr, table, cols, width))


def _convert_multisphere(native: Path, particles: Path, out_contacts: Path,
                         out_particles: Path, wall_rows, steps=None) -> dict:
    """The conversion shared by LIGGGHTS' multisphere decks: sphere frames become rods
    (body id ``id_multisphere``), sphere-sphere contacts (geometry recomputed from the
    frame) and the deck's sphere-wall rows, ``wall_rows(frame, table, columns, step)`` ->
    :class:`analysis.frame.Contacts` (``table`` the dump rows in ``frame`` order), merge
    per rod pair and per rod and wall (:func:`_write_glued_frame`). Both dumps must hold
    the same steps (and ``steps``, when given). Returns ``{"dropped": sphere pairs within
    the neighbour cutoff but not touching}``."""
    from analysis.frame import Contacts
    from analysis.io import read_particle_frames

    spheres = {f.step: f for f in read_particle_frames(particles)}
    if steps is not None and sorted(spheres) != list(steps):
        raise EngineError(f"{particles}: frames at steps {sorted(spheres)[:5]}... are not the "
                          f"planned {len(steps)} frames from step {steps[0]}")
    body, walls = {}, {}
    for step, _b, _p, cols, table in _iter_dump(particles):
        c = {name: k for k, name in enumerate(cols)}
        order = np.argsort(table[:, c["id"]], kind="stable")
        body[step] = table[order, c["id_multisphere"]].astype(np.int64)
        walls[step] = wall_rows(spheres[step], table[order], cols, step)
    local = {step: table for step, _box, _cols, table in _iter_local(native)}
    odd = sorted(set(local) ^ set(spheres))
    if odd:
        raise EngineError(f"{native} and {particles}: frames at steps {odd[:5]} are in one "
                          "file only")
    dropped = 0
    with open(io.part_path(out_contacts), "w") as fc, open(io.part_path(out_particles), "w") as fp:
        for step in sorted(spheres):
            table, fr = local[step], spheres[step]
            ids_i, ids_j = table[:, 6], table[:, 7]
            n, delta, point = _geometry(fr, ids_i, ids_j)
            keep = delta > 0
            dropped += int(np.count_nonzero(~keep))
            sph = Contacts(step, ids_i[keep].astype(np.int64), ids_j[keep].astype(np.int64),
                           point[keep], n[keep], delta[keep], table[keep, 9:12])
            _write_glued_frame(fp, fc, fr, _with_walls(sph, walls[step]), body[step])
    io.finalize(out_contacts)
    io.finalize(out_particles)
    return {"dropped": dropped}


def convert_deposit(work: Path, case: dict, data: Path) -> dict:
    """The deposition deck's output in ``work`` -> full-precision box bounds, rods and rod
    contacts (:func:`convert_multisphere_rods`)."""
    restore_box_precision(work / "particles.dump", work / "box.dat", data)
    stats = convert_multisphere_rods(work / "contacts.native", work / "particles.dump",
                                     work / "contacts.dump", work / "rods.dump",
                                     float(case["container"]["width"]))
    os.replace(work / "rods.dump", work / "particles.dump")
    return stats


# -- LIGGGHTS random packings of rods: gravity settling (inputs/liggghts/in.rods.settle) -------
# LIGGGHTS cannot compress multisphere rods (fix deform is refused with fix multisphere) nor
# read our random start; a compression case that has a protocol.settle block runs on it as
# the settling of randomly inserted rods onto a floor in a box periodic in x and y, and the
# analysis measures phi_J and z_J in a bulk window of the bed (analysis.summary.
# analyse_settled). What differs from the compression is said in the deck's header.

#: wall id of the floor in the contact table of a settled bed (its only wall)
SETTLE_FLOOR_ID = -1


#: rod volume over the volume of the part of the insertion column their centres can use
#: (fix insert/pack keeps a rod's bounding sphere, diameter L + D, inside the column: also
#: across the periodic faces): measured at most 0.50-0.52 (alpha 1 in W = 8 D, alpha 4 in
#: W = 12 D; 0.15 and 0.26 of the whole column)
PHI_INSERT_SETTLE = 0.35


def settle_plan(case: dict) -> dict:
    """The validated case's ``protocol.settle`` block (defaults from the case schema) with
    ``n`` defaulting to ``particles.n``: ``n`` rods, periodic box side ``width`` and
    ``gravity`` (units of the case), ``bulk`` margins (in particle lengths ``L + D``),
    ``ke_ratio``, ``max_time`` (time), ``dump_every`` (steps)."""
    given = case["protocol"].get("settle")
    if given is None:
        raise EngineError("the case has no protocol.settle block (LIGGGHTS' gravity settling "
                          "of rods needs one: width, and optionally n, gravity, bulk)")
    return {"n": case["particles"]["n"], **given}


def liggghts_settle_support(case: dict) -> str | None:
    """``None`` when ``in.rods.settle`` can stand in for the compression of the (3-D
    rod) case on LIGGGHTS, else the reason."""
    p, c, pr = case["particles"], case["contact"], case["protocol"]
    if "settle" not in pr:
        return ("LIGGGHTS cannot compress multisphere rods with fix deform ('fix deform and fix "
                "multisphere are incompatible', shared/engines.md); add protocol.settle to run "
                "its gravity-settling substitute (inputs/liggghts/in.rods.settle)")
    if p["diameter"].get("distribution", "mono") != "mono":
        return "the LIGGGHTS settling deck has one rod template: equal diameters (mono) only"
    if c["law"] != "hooke" or c.get("friction", 0.0) > 0:
        return ("the LIGGGHTS settling deck implements the frictionless linear law only (got law "
                f"{c['law']}, friction {c.get('friction', 0.0)})")
    if pr.get("integrator", "verlet") != "verlet":
        return "liggghts integrates inertial dynamics only (no overdamped integrator)"
    return None


def settle_column_height(case: dict) -> float:
    """Height of the column LIGGGHTS inserts the settling rods into (length): the rod
    volume fills :data:`PHI_INSERT_SETTLE` of the part of it their centres can use (a
    square of side ``W - (L + D)``), plus one rod length ``L + D``."""
    from rodcase.case import particle_measure

    p = case["particles"]
    plan = settle_plan(case)
    d = p["diameter"]["mean"]
    reach = (1.0 + p["aspect_ratio"]) * d
    volume = plan["n"] * particle_measure(d, p["aspect_ratio"], 3)
    return volume / (PHI_INSERT_SETTLE * (plan["width"] - reach) ** 2) + reach


def liggghts_settle_vars(case: dict) -> dict[str, str]:
    """``-var`` values of ``inputs/liggghts/in.rods.settle`` for a compression case with a
    ``protocol.settle`` block (:func:`settle_plan`): the compression's contact law
    (``k_n``, ``gamma_n``, drag ``gamma_bg`` per rod), time step and glued-sphere spacing;
    the settle block's rod number, box side, gravity and stop (kinetic energy below
    ``ke_ratio`` of its peak, or ``max_time``)."""
    reason = liggghts_settle_support(case)
    if reason:
        raise EngineError(reason)
    p, c, pr = case["particles"], case["contact"], case["protocol"]
    plan = settle_plan(case)
    d = p["diameter"]["mean"]
    length = p["aspect_ratio"] * d
    dt = pr["dt"]
    every = case.get("output", {}).get("thermo_every", 1000)
    v = {"width": plan["width"], "height": settle_column_height(case), "n_rods": plan["n"],
         "radius": d / 2, "length": length,
         "spheres": glued_spheres(length, d, p.get("glued_spacing", 0.25)),
         "density": p.get("density", 1.0), "k_n": c["k_n"], "gamma_n": c.get("gamma_n", 0.0),
         "gamma_bg": c.get("gamma_bg", 0.0), "g": plan["gravity"],
         "seed": _insertion_seed(case.get("seed", 1)), "dt": dt,
         "check_every": every, "thermo_every": every, "min_steps": every,
         "max_steps": int(np.ceil(plan["max_time"] / dt)),
         "settle_ratio": plan["ke_ratio"], "dump_every": plan["dump_every"], "skin": 0.2 * d}
    return {k: repr(float(x)) if isinstance(x, float) else str(x) for k, x in v.items()}


def floor_contacts(frame, table, cols):
    """Sphere-floor contacts of the settling deck from the floor force it stores on each
    sphere (``f_force_floor[1..3]`` columns of the sphere dump, rows in ``frame`` order):
    one row per sphere with a nonzero force, ``j`` = :data:`SETTLE_FLOOR_ID`, normal
    ``-z`` (towards the floor), overlap ``R - z``, point in the middle of the overlap,
    force on the sphere. Returns a :class:`analysis.frame.Contacts`."""
    from analysis.frame import Contacts

    c = {name: k for k, name in enumerate(cols)}
    force = table[:, [c[f"f_force_floor[{k}]"] for k in (1, 2, 3)]]
    on = np.flatnonzero(np.any(force != 0.0, axis=1))
    normal = np.tile([0.0, 0.0, -1.0], (len(on), 1))
    overlap = frame.radius[on] - frame.x[on, 2]
    point = frame.x[on] + (frame.radius[on] - 0.5 * overlap)[:, None] * normal
    return Contacts(frame.step, frame.ids[on].astype(np.int64),
                    np.full(len(on), SETTLE_FLOOR_ID, dtype=np.int64), point, normal, overlap,
                    force[on])


def convert_settled_rods(native: Path, particles: Path, out_contacts: Path,
                         out_particles: Path) -> dict:
    """Output of the settling deck (multisphere rods) -> rods and contacts in the common
    format, as :func:`convert_multisphere_rods` does for the deposition deck: sphere frames
    (``id id_multisphere type x y z radius f_force_floor[1..3]``) become rods (body id =
    rod id), sphere-sphere contacts (geometry recomputed from the frame, minimum image
    across the periodic x and y) and sphere-floor contacts (:func:`floor_contacts`) merge
    per rod pair and per rod (a rod lying flat on the floor: one merged row)."""
    return _convert_multisphere(native, particles, out_contacts, out_particles,
                                lambda fr, table, cols, _step: floor_contacts(fr, table, cols))


def convert_settle(work: Path, case: dict, data: Path) -> dict:
    """The settling deck's output in ``work`` -> full-precision box bounds, rods and rod
    contacts, the floor's included (:func:`convert_settled_rods`)."""
    restore_box_precision(work / "particles.dump", work / "box.dat", data)
    stats = convert_settled_rods(work / "contacts.native", work / "particles.dump",
                                 work / "contacts.dump", work / "rods.dump")
    os.replace(work / "rods.dump", work / "particles.dump")
    return stats


# -- LIGGGHTS tapping: multisphere rods on a moving mesh base (inputs/liggghts/in.rods.tap) -----
#: wall fixes of LIGGGHTS' tapping deck (fix wall/gran ... store_force yes) in pysim's wall
#: order (wall id -(k + 1)): the base plane first, then the cylinder
LIGGGHTS_TAP_WALLS = ("wbase", "wcyl")


def liggghts_tap_support(case: dict) -> str | None:
    """``None`` when LIGGGHTS' tapping deck (``inputs/liggghts/in.rods.tap``) can run a
    tapping case of 3-D rods, else the reason."""
    p, c = case["particles"], case["contact"]
    if p["diameter"].get("distribution", "mono") != "mono":
        return "the LIGGGHTS tapping deck has one rod template: equal diameters (mono) only"
    if c["law"] != "hooke":
        return (f"the LIGGGHTS tapping deck implements the linear law (hooke/stiffness) only, "
                f"not law {c['law']}")
    if c.get("k_t", 0.0) <= 0.0:
        return ("the LIGGGHTS tapping deck needs a tangential stiffness k_t > 0 (its "
                f"tangential history model divides by it), got {c.get('k_t', 0.0)}")
    if case["container"].get("shape") != "cylinder":
        return (f"the LIGGGHTS tapping deck runs in a cylinder, not container shape "
                f"{case['container'].get('shape')!r}")
    d = p["diameter"]["mean"]
    if not 0.5 * case["container"]["diameter"] > 0.5 * (1.0 + p["aspect_ratio"]) * d:
        return ("LIGGGHTS inserts a rod only where its bounding sphere (diameter L + D) fits "
                "inside the cylinder: the container diameter must exceed L + D")
    return None


def liggghts_tap_column(case: dict) -> float:
    """Top of the column LIGGGHTS inserts the tapping rods into (length): pysim's column
    (:func:`pysim.initial.random_spherocylinders_in_cylinder`, packing fraction
    ``phi_init``) for the rod centres, raised where fix insert/pack cannot place them that
    densely (:data:`PHI_INSERT` of the cylinder of radius ``R_c - (L + D)/2`` that the
    centres can use), plus one bounding-sphere diameter ``L + D``."""
    p = case["particles"]
    d = p["diameter"]["mean"]
    length = p["aspect_ratio"] * d
    rc = 0.5 * case["container"]["diameter"]
    total = p["n"] * (np.pi * d * d * length / 4.0 + np.pi * d**3 / 6.0)
    reach = length + d  # bounding-sphere diameter
    column = max(total / (case["protocol"]["phi_init"] * np.pi * rc * rc), reach)
    centres = np.pi * (rc - 0.5 * reach) ** 2  # area the bounding spheres' centres can use
    return float(max(column, total / (PHI_INSERT * centres)) + reach)


def liggghts_tap_vars(case: dict) -> dict[str, str]:
    """``-var`` values of LIGGGHTS' tapping deck (``inputs/liggghts/in.rods.tap``).

    The same step plan, base motion and frame steps as pysim and LAMMPS
    (:func:`pysim.protocols.tapping.plan`, :func:`tap_deck_vars`); rods are multisphere
    templates of :func:`glued_spheres` spheres (the case's ``glued_spacing``) with the mass
    and inertia of the solid spherocylinder; the contact law is pysim's linear
    spring-dashpot with its ``k_n``, ``gamma_n``, ``k_t``, ``gamma_t`` (absolute damping,
    N/m and N s/m in SI cases) and friction (the mismatches of LIGGGHTS' tangential model
    are listed in the deck's header). The rods are inserted at random at rest below
    :func:`liggghts_tap_column` (not pysim's start: the same number of rods only).
    """
    from pysim.protocols.tapping import plan, settle_drag

    reason = liggghts_tap_support(case)
    if reason:
        raise EngineError(reason)
    p, c, pr = case["particles"], case["contact"], case["protocol"]
    tp = plan(pr, case["gravity"])
    d = p["diameter"]["mean"]
    length = p["aspect_ratio"] * d
    v = {"n_rods": p["n"], "radius": d / 2, "length": length,
         "spheres": glued_spheres(length, d, p.get("glued_spacing", 0.25)),
         "density": p.get("density", 1.0), "radius_c": 0.5 * case["container"]["diameter"],
         "height": liggghts_tap_column(case), "k_n": c["k_n"], "gamma_n": c.get("gamma_n", 0.0),
         "k_t": c["k_t"], "gamma_t": c.get("gamma_t", 0.0), "mu": c.get("friction", 0.0),
         "mu_wall": c.get("wall_friction", c.get("friction", 0.0)), "g": case["gravity"],
         "dt": pr["dt"], "drag": settle_drag(case)[0], "settle_steps": tp.settle_steps,
         "relax_steps": tp.start - tp.settle_steps, "freq": 1.0 / tp.period,
         "amp": tp.amplitude, "taps": pr["taps"], "frames_per_tap": tp.frames_per_tap,
         "thermo_every": case.get("output", {}).get("thermo_every", 1000),
         "seed": _insertion_seed(case.get("seed", 1)),
         # the skin of LAMMPS' tapping deck (rods thrown off a landing column move fast)
         "skin": 0.4 * d}
    return {k: repr(float(x)) if isinstance(x, float) else str(x) for k, x in v.items()}


def liggghts_tap_wall_contacts(frame, table, cols, radius_c: float, z_base: float):
    """Sphere-wall contacts of LIGGGHTS' tapping deck from the wall forces it stores on each
    sphere (``f_force_wbase[1..3]``, ``f_force_wcyl[1..3]`` columns of the sphere dump,
    rows in ``frame`` order): one row per sphere and wall with a nonzero force, ``j`` = -1
    for the base (at height ``z_base``, normal ``-z``, overlap ``R - (z - z_base)``) and -2
    for the cylinder of radius ``radius_c`` about the z axis (normal radially outwards,
    overlap ``R - (radius_c - r)``), pysim's numbering; contact point in the middle of the
    overlap, force on the sphere. Returns a :class:`analysis.frame.Contacts`."""
    from analysis.frame import Contacts

    c = {name: k for k, name in enumerate(cols)}
    rows = []
    for w, fix in enumerate(LIGGGHTS_TAP_WALLS):
        force = table[:, [c[f"f_force_{fix}[{k}]"] for k in (1, 2, 3)]]
        on = np.flatnonzero(np.any(force != 0.0, axis=1))
        x = frame.x[on]
        normal = np.zeros((len(on), 3))
        if fix == "wbase":
            normal[:, 2] = -1.0
            gap = x[:, 2] - z_base
        else:
            r = np.hypot(x[:, 0], x[:, 1])
            normal[:, 0] = x[:, 0] / np.where(r > 0, r, 1.0)
            normal[:, 1] = x[:, 1] / np.where(r > 0, r, 1.0)
            gap = radius_c - r
        overlap = frame.radius[on] - gap
        point = x + (frame.radius[on] - 0.5 * overlap)[:, None] * normal
        rows.append((frame.ids[on], np.full(len(on), -(w + 1)), point, normal, overlap,
                     force[on]))
    i, j, point, normal, overlap, force = (np.concatenate(x) for x in zip(*rows))
    return Contacts(frame.step, i.astype(np.int64), j.astype(np.int64), point, normal, overlap,
                    force)


def convert_liggghts_tap(work: Path, case: dict) -> dict:
    """Output of LIGGGHTS' tapping deck in ``work`` -> ``rods.dump`` and ``contacts.dump``
    (common format) there.

    As :func:`convert_multisphere_rods`: spheres become rods (body id ``id_multisphere``),
    sphere-sphere contacts (geometry recomputed from the frame) and sphere-wall contacts
    (:func:`liggghts_tap_wall_contacts`, base at the plan's height of the frame's step)
    merge per rod pair and per rod and wall. Raises :class:`EngineError` when the frames
    are not those of the plan (:func:`pysim.protocols.tapping.plan`).
    """
    from pysim.protocols.tapping import plan

    tp = plan(case["protocol"], case["gravity"])
    rc = 0.5 * case["container"]["diameter"]
    return _convert_multisphere(
        work / "contacts.native", work / "particles.dump", work / "contacts.dump",
        work / "rods.dump",
        lambda fr, table, cols, step: liggghts_tap_wall_contacts(
            fr, table, cols, rc, float(tp.base_height(step))),
        steps=[int(x) for x in tp.frame_steps])


def convert_tap(work: Path, case: dict, data: Path) -> dict:
    """The tapping deck's output in ``work`` -> rods and rod contacts
    (:func:`convert_liggghts_tap`; the container is fixed: no box to restore)."""
    stats = convert_liggghts_tap(work, case)
    os.replace(work / "rods.dump", work / "particles.dump")
    return stats


def liggghts_latest_restart(work: Path) -> Path | None:
    """The newest complete restart file (``restart.<step>``) of an interrupted LIGGGHTS
    tapping run in ``work``, or None: each candidate, newest first, is read back by
    LIGGGHTS itself (:func:`liggghts_restart_is_complete`), as :func:`latest_restart`
    does for LAMMPS."""
    return _newest_complete(work, liggghts_restart_is_complete)


def liggghts_restart_is_complete(path: Path) -> bool:
    """Whether LIGGGHTS reads the restart file ``path`` of the tapping deck (in a child
    process). A file cut short while being written fails ("Did not assign all atoms");
    one missing only its last few bytes may still read (measured: 32 of 60,000 bytes)."""
    exe = shutil.which("liggghts")
    if exe is None:
        return False
    script = path.parent / "restart_check.in"
    script.write_text("atom_style granular\natom_modify map array\nboundary f f fm\n"
                      "newton off\ncommunicate single vel yes\nunits si\n"
                      f"read_restart {path.name}\nprint 'rodpack: restart read'\nquit\n")
    r = subprocess.run([exe, "-in", script.name, "-log", "none"], cwd=path.parent,
                       capture_output=True, text=True, errors="replace", timeout=300)
    script.unlink()
    return "rodpack: restart read" in r.stdout


# -- running -----------------------------------------------------------------------------------
#: the version line LIGGGHTS prints first
VERSION = r"^(LIGGGHTS \(.*?\))"


def command(deck: Path, outdir: Path, ranks: int, args: list[str]) -> list[str]:
    """``liggghts -in deck -log outdir/log.liggghts args`` (Debian's), under ``mpirun -np
    ranks`` when ``ranks > 1``."""
    exe = shutil.which("liggghts")
    if exe is None:
        raise EngineError("liggghts is not installed (as root: apt-get install liggghts)")
    pre = []
    if ranks > 1:
        pre = [shutil.which("mpirun") or "mpirun", "--allow-run-as-root", "-np", str(ranks)]
    return pre + [exe, "-in", str(deck), "-log", str(outdir / "log.liggghts")] + args
