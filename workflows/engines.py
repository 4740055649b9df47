"""Driving LAMMPS and LIGGGHTS with a rodpack case, and turning what they write into
the common format (``docs/formats.md``).

Each engine runs its deck from ``inputs/<engine>/`` with ``-var`` values derived from
the case (:func:`deck_vars`) inside a work directory; its native contact output
(``contacts.native``) is converted to ``contacts.dump`` using the particle positions
of the same step, so that every engine's contact table has identical columns and
conventions. A run that fails, hangs past its budget or loses atoms raises
:class:`EngineError` naming the engine's own error line and its log.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from pysim import io
from workflows.stopping import check_signalled, stop_process

PROJECT_ROOT = Path(__file__).resolve().parents[1]
#: where the decks live; RODPACK_INPUTS points elsewhere (tests use it to break a deck)
INPUTS = Path(os.environ.get("RODPACK_INPUTS", PROJECT_ROOT / "inputs"))


class EngineError(RuntimeError):
    """An engine run failed; the message names the engine's error line and log file."""


def kind(case: dict) -> str:
    """``spheres`` (3-D, ``L = 0``), ``rods`` (3-D spherocylinders) or ``2d``."""
    p = case["particles"]
    if p.get("dimension", 3) == 2:
        return "2d"
    return "rods" if p.get("aspect_ratio", 0.0) > 0 else "spheres"


def supports(engine: str, case: dict) -> str | None:
    """``None`` when the engine can run the case, else the reason it cannot."""
    if engine == "pysim":
        return None
    if case["contact"].get("limit_damping", False) and engine == "lammps-body":
        return ("contact.limit_damping: LAMMPS' body pair styles have no limit_damping "
                "option; use engine 'lammps' (glued rods) or pysim")
    if case["contact"].get("spine_contact", "closest") != "closest":
        return (f"{engine} has no end-bond rod contacts (contact.spine_contact = "
                f"{case['contact']['spine_contact']} is pysim's)")
    if case["contact"].get("tangential_spring", "reset") != "reset":
        return (f"{engine}'s tangential history is cut back to the Coulomb limit when a contact "
                "slides; contact.tangential_spring = keep (the spring grows on) is pysim's only")
    if case["protocol"].get("preparation", {}).get("mode", "capped") != "capped":
        return (f"the {engine} tapping deck settles under the capping drag for settle_time; "
                "protocol.preparation.mode = free (settle until the kinetic energy is gone) "
                "is pysim's only")
    k = kind(case)
    name = case["protocol"]["name"]
    if engine == "lammps-body":
        if name != "compress":
            return f"lammps-body runs the 'compress' protocol only, not '{name}'"
        if k == "spheres" or case["particles"].get("aspect_ratio", 0.0) <= 0:
            return "lammps-body is for rods (aspect_ratio > 0); spheres and disks run on 'lammps'"
        if k == "rods":
            c = case["contact"]
            if c["law"] != "hooke" or c.get("friction", 0.0) > 0:
                return ("the lammps-body 3-D deck implements the frictionless linear law only "
                        f"(got law {c['law']}, friction {c.get('friction', 0.0)})")
            if "pressure_final" in case["protocol"]:
                return "the lammps-body 3-D deck has no pressure_final stop"
    if name == "tapping":
        if k != "rods":
            return f"the {engine} tapping deck is for rods (aspect_ratio > 0)"
        if engine == "liggghts":
            return liggghts_tap_support(case)
        return None
    if name == "deposit":
        if k != "rods":
            return f"the {engine} deposition deck is for 3-D rods (aspect_ratio > 0, dimension 3)"
        if engine == "liggghts":
            return liggghts_deposit_support(case)
        return None
    if name != "compress":
        return (f"{engine} runs only the 'compress', 'tapping' and 'deposit' protocols here, "
                f"not '{name}'")
    if k == "2d":
        if engine not in ("lammps", "lammps-body"):
            return f"{engine} has no 2-D deck"
        if case["contact"]["law"] != "harmonic" or case["contact"].get("friction", 0.0) > 0:
            return ("the LAMMPS 2-D deck implements the frictionless soft harmonic law only "
                    f"(got law {case['contact']['law']})")
        return None  # overdamped: emulated by strong drag against the deforming box
    if case["protocol"].get("integrator", "verlet") != "verlet":
        return f"{engine} integrates inertial dynamics only (no overdamped integrator)"
    if k == "rods" and engine == "liggghts":  # settles under gravity instead (protocol.settle)
        return liggghts_settle_support(case)
    return None


def deck(engine: str, case: dict) -> Path:
    """The input deck that runs a case on an engine."""
    reason = supports(engine, case)
    if reason:
        raise EngineError(reason)
    if engine == "lammps-body":
        return INPUTS / "lammps" / f"in.{'2d' if kind(case) == '2d' else 'rods'}.body.compress"
    if settles(engine, case):
        return INPUTS / "liggghts" / "in.rods.settle"
    return INPUTS / engine / f"in.{kind(case)}.{DECK_SUFFIX[case['protocol']['name']]}"


#: deck file suffix of each protocol the peer engines run
DECK_SUFFIX = {"compress": "compress", "tapping": "tap", "deposit": "deposit"}


def glued_spheres(length: float, diameter: float, spacing: float) -> int:
    """Number of equal spheres that glue into a rod: end spheres at the spine ends, centre
    spacing at most ``spacing * D``."""
    if length <= 0:
        return 1
    return int(np.ceil(length / (spacing * diameter) - 1e-9)) + 1


def _rod_vars(case: dict) -> dict:
    """Spheres per glued rod and the ghost cutoff ``fix rigid/small`` needs (a body
    reaches as far as its length from its owner atom)."""
    from rodcase.case import size_extremes

    p = case["particles"]
    d = p["diameter"]["mean"]
    dmax = size_extremes(p["diameter"])[2]
    return {"spheres": glued_spheres(p["aspect_ratio"] * d, d, p.get("glued_spacing", 0.25)),
            "ghost_cut": (p["aspect_ratio"] + 1.0) * dmax + 0.2 * dmax}


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


def _insertion_seed(seed: int) -> int:
    """A prime above 10000 for LIGGGHTS' insertion (its seeds must be primes > 10000),
    one per case seed."""
    k = 10007 + 1000 * int(seed)
    while any(k % f == 0 for f in range(2, int(k**0.5) + 1)):
        k += 1
    return k


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


def _ke_peak(screen: Path, step: int) -> float:
    """Running peak of the kinetic energy printed by the deposition deck at its last
    check at or before ``step`` (``rodpack: step S ke K peak P``); 0 when none."""
    peak = 0.0
    if screen.exists():
        for m in re.finditer(r"rodpack: step (\d+) ke \S+ peak (\S+)", screen.read_text()):
            if int(m.group(1)) <= step:
                peak = float(m.group(2))
    return peak


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


def settles(engine: str, case: dict) -> bool:
    """Whether ``engine`` runs the compression case ``case`` as gravity settling
    (LIGGGHTS with rods: ``inputs/liggghts/in.rods.settle``)."""
    return (engine == "liggghts" and kind(case) == "rods"
            and case["protocol"]["name"] == "compress")


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
# -- end of LIGGGHTS random packings of rods --------------------------------------------------------


def restart_interval(case: dict) -> int:
    """Steps between LAMMPS restart files: every :data:`RESTART_DUMPS` dump intervals
    (tapping: frame intervals; deposition: thermo rows)."""
    if case["protocol"]["name"] == "tapping":
        from pysim.protocols.tapping import plan

        tp = plan(case["protocol"], case["gravity"])
        return RESTART_DUMPS * max(int(np.diff(tp.frame_steps).max()), 1)
    if case["protocol"]["name"] == "deposit":  # few frames: every 10 settling checks
        return RESTART_DUMPS * case.get("output", {}).get("thermo_every", 1000)
    return RESTART_DUMPS * case.get("output", {}).get("dump_every", 4000)


#: density per area of LAMMPS' 2-D rods: the overdamped limit needs m / (k_d A) = rho / k_d
#: well below the compression's time scales (rho / k_d = 0.05 t_0; damping ratio ~3)
RHO_2D = 0.05


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


def deck_vars(case: dict, engine: str) -> dict[str, str]:
    """``-var`` values of the case's deck (compression, tapping or deposition), with the
    normal-force clip of ``contact.limit_damping`` (:func:`_clip_vars`)."""
    return {**_deck_vars(case, engine), **_clip_vars(case, engine)}


def _clip_vars(case: dict, engine: str) -> dict[str, str]:
    """``contact.limit_damping`` as the decks take it: LAMMPS ``-var limit_damping 1`` (its
    ``limit_damping`` keyword on the pair style and the walls), LIGGGHTS ``-var limit_force
    on`` (``limitForce``); nothing when it is off, nor for the 2-D and body decks, whose
    contact laws have no dashpot (2-D) or no clip (body styles; refused by
    :func:`supports`)."""
    if not case["contact"].get("limit_damping", False) or kind(case) == "2d":
        return {}
    if engine == "lammps":
        return {"limit_damping": "1"}
    if engine == "liggghts":
        return {"limit_force": "on"}
    return {}


def _deck_vars(case: dict, engine: str) -> dict[str, str]:
    if case["protocol"]["name"] == "tapping":
        return liggghts_tap_vars(case) if engine == "liggghts" else tap_deck_vars(case)
    if case["protocol"]["name"] == "deposit":
        return liggghts_deposit_vars(case) if engine == "liggghts" else deposit_deck_vars(case)
    if settles(engine, case):
        return liggghts_settle_vars(case)
    if kind(case) == "2d":
        v = deck_vars_2d(case)
        if engine == "lammps-body":  # one body per rod: no disks, no ghost cutoff, masses
            for key in ("disks", "rho_disk", "ghost_cut"):
                v.pop(key)
            v["m_small"] = repr(RHO_2D * float(v["a_small"]))
        return v
    c, pr = case["contact"], case["protocol"]
    out = case.get("output", {})
    v = {
        "k_n": c["k_n"], "gamma_n": c.get("gamma_n", 0.0), "mu": c.get("friction", 0.0),
        "k_t": c.get("k_t", 0.0), "gamma_bg": c.get("gamma_bg", 0.0), "dt": pr["dt"],
        "phi_init": pr["phi_init"], "rate": pr["rate"], "phi_final": pr["phi_final"],
        "thermo_every": out.get("thermo_every", 1000), "dump_every": out.get("dump_every", 4000),
    }
    if "phi_fast" in pr:
        v["phi_fast"], v["rate_fast"] = pr["phi_fast"], pr["rate_fast"]
    else:  # no fast stage: a zero-length one
        v["phi_fast"], v["rate_fast"] = pr["phi_init"], 1.0
    if "pressure_final" in pr:
        v["p_final"] = pr["pressure_final"]
    if kind(case) == "rods" and engine == "lammps-body":  # one body per rod
        from rodcase.case import size_extremes

        for key in ("mu", "k_t"):
            v.pop(key)
        v["d_max"] = size_extremes(case["particles"]["diameter"])[2]
    elif kind(case) == "rods":  # friction between the glued spheres of different rods
        v.update(_rod_vars(case))
        gamma_n = c.get("gamma_n", 0.0)
        v["x_gamma_t"] = c.get("gamma_t", 0.0) / gamma_n if gamma_n > 0 else 0.0
    elif engine == "lammps":
        v["x_gamma_t"] = 0.0
    else:
        v["gamma_t"] = c.get("gamma_t", 0.0)
    return {k: repr(float(x)) if isinstance(x, float) else str(x) for k, x in v.items()}


def venv_bin(name: str) -> str:
    """An executable of the Python environment running this code (``lmp``, ``mpiexec``)."""
    path = Path(sys.executable).parent / name
    if path.exists():
        return str(path)
    found = shutil.which(name)
    if found is None:
        raise EngineError(f"'{name}' not found next to {sys.executable} nor on PATH; "
                          "run 'make setup'")
    return found


#: prefixes of the variables with which SLURM and its PMI describe the job step that runs
#: the runner. An engine that inherits them takes itself for a rank that srun started:
#: Debian's Open MPI (LIGGGHTS) then aborts in MPI_Init, built without SLURM's PMI, and
#: mpirun and MPICH's mpiexec start their ranks with a nested srun, which waits for the
#: CPUs that the step itself holds.
JOB_STEP_PREFIXES = ("SLURM", "PMI_", "PMIX_")


def engine_env() -> dict:
    """This process's environment less the batch system's job-step variables
    (:data:`JOB_STEP_PREFIXES`): an engine and its MPI ranks start on this node as on a
    workstation, inside the CPUs that the job holds (an engine job is one task on one node
    with a CPU per rank)."""
    return {k: v for k, v in os.environ.items() if not k.startswith(JOB_STEP_PREFIXES)}


def command(engine: str, data: Path, outdir: Path, case: dict, ranks: int = 1,
            extra_vars: dict | None = None) -> list[str]:
    """The command line that runs the case's deck."""
    args = []
    for k, val in {**deck_vars(case, engine), **(extra_vars or {})}.items():
        args += ["-var", k, str(val)]
    args += ["-var", "data", str(data), "-var", "outdir", str(outdir)]
    path = deck(engine, case)
    if engine in ("lammps", "lammps-body"):
        exe = [venv_bin("lmp")]
        if ranks > 1:
            exe = [venv_bin("mpiexec"), "-n", str(ranks)] + exe
        return exe + ["-in", str(path), "-log", str(outdir / "log.lammps")] + args
    if engine == "liggghts":
        exe = shutil.which("liggghts")
        if exe is None:
            raise EngineError("liggghts is not installed (as root: apt-get install liggghts)")
        pre = []
        if ranks > 1:
            pre = [shutil.which("mpirun") or "mpirun", "--allow-run-as-root", "-np", str(ranks)]
        return pre + [exe, "-in", str(path), "-log", str(outdir / "log.liggghts")] + args
    raise ValueError(f"unknown engine {engine!r}; valid: lammps, lammps-body, liggghts")


def engine_version(engine: str, screen: str) -> str:
    """Version line the engine printed first (``LAMMPS (22 Jul 2025 - Update 4)``)."""
    pat = r"^(LAMMPS \(.*\))" if engine.startswith("lammps") else r"^(LIGGGHTS \(.*?\))"
    m = re.search(pat, screen, re.M)
    return m.group(1) if m else "unknown"


def _error_line(text: str) -> str | None:
    for line in text.splitlines():
        if line.startswith("ERROR"):
            return line.strip()
    return None


#: what a peer's error line has meant in our decks, added to the failure message
ERROR_HINTS = {
    "Rigid body atoms": "glued rods blew up: the sphere contacts between two rods (up to "
                        "tens of them) act as parallel springs and dashpots, and the time "
                        "step was too large for them (tapping at spacing D/4 and dt 2e-5 s: "
                        "speeds grew a thousandfold in 15 steps); try a smaller protocol.dt",
}


def failure_message(engine: str, returncode: int, text: str, screen: Path) -> str:
    """One line for a failed peer run: exit code, the engine's first ``ERROR`` line (or
    its last line), a hint where :data:`ERROR_HINTS` knows the error, and the log."""
    err = _error_line(text)
    line = err or (text.strip().splitlines()[-1] if text.strip() else "no output")
    hints = [h for key, h in ERROR_HINTS.items() if key in line]
    return (f"{engine} failed (exit {returncode}): {line}"
            + "".join(f" ({h})" for h in hints) + f"; log: {screen}")


def resume_stamp(engine: str, case: dict, data) -> dict:
    """What identifies a run for resuming (``resume.json``): engine, case hash and the
    initial data's hash."""
    from rodcase.case import case_hash

    return {"engine": engine, "case_hash": case_hash(case),
            "data": hashlib.sha256(Path(data).read_bytes()).hexdigest()}


def run(engine: str, case: dict, data: Path, outdir: Path, ranks: int = 1,
        timeout: float = 3600.0) -> dict:
    """Run one engine on a case and leave the common-format files in ``outdir``.

    The engine works in ``outdir/work``; only complete, converted files are moved to
    ``outdir``. Returns a summary for the provenance record.
    """
    outdir = Path(outdir)
    work = outdir / "work"
    extra = {}
    # resume only an interrupted run of this very case and start
    stamp = resume_stamp(engine, case, data)
    same = work.exists() and (work / "resume.json").exists() and \
        json.loads((work / "resume.json").read_text()) == stamp
    lammps = engine in ("lammps", "lammps-body")
    restart = latest_restart(work) if lammps and same else None
    lig_tap = engine == "liggghts" and case["protocol"]["name"] == "tapping"  # resumes too
    if lig_tap and same:
        restart = liggghts_latest_restart(work)
    if restart is not None:
        step = int(restart.name.split(".")[-1])
        cut_outputs(work, step)
        extra["restart_file"] = str(restart.resolve())
        extra["resume"] = 1
        if case["protocol"]["name"] == "deposit":
            extra["ke_peak"] = repr(_ke_peak(work / "screen.txt", step))
    else:
        if work.exists():
            shutil.rmtree(work)
        work.mkdir(parents=True)
        io.atomic_write_text(work / "resume.json", json.dumps(stamp))
    if lammps or lig_tap:
        extra["restart_every"] = restart_interval(case)
    engine_data = Path(data).resolve()
    body = engine == "lammps-body"
    # LIGGGHTS rods: multisphere bodies inserted by the deck itself (no data file)
    multisphere = engine == "liggghts" and kind(case) == "rods"
    if multisphere:
        ranks = 1  # the PUBLIC version runs multisphere bodies on one rank only
    glued = kind(case) in ("rods", "2d") and not body and not multisphere
    if body:
        engine_data = (work / "bodies.data").resolve()
        if restart is None or not engine_data.exists():
            (work / "measure.txt").write_text(repr(write_body_data(data, engine_data, case)))
        extra["arods" if kind(case) == "2d" else "vrods"] = \
            (work / "measure.txt").read_text().strip()
    if glued:
        engine_data = (work / "glued.data").resolve()
        if restart is None or not engine_data.exists():
            vrods = write_glued_data(data, engine_data, case)
            (work / "vrods.txt").write_text(repr(float(vrods)))
        extra["arods" if kind(case) == "2d" else "vrods"] = \
            (work / "vrods.txt").read_text().strip()
    cmd = command(engine, engine_data, work.resolve(), case, ranks, extra)
    screen_path = work / "screen.txt"
    env = dict(engine_env(), OMP_NUM_THREADS="1")
    t0 = time.perf_counter()
    with open(screen_path, "w") as screen:
        proc = _run_pruning(cmd, screen, work, env, timeout)
        if proc is None:
            raise EngineError(f"{engine} ran past its budget of {timeout:g} s; "
                              f"log: {screen_path}")
    wall = time.perf_counter() - t0
    check_signalled(engine, proc.returncode)
    text = screen_path.read_text(errors="replace")
    if proc.returncode != 0 or _error_line(text):
        raise EngineError(failure_message(engine, proc.returncode, text, screen_path))
    if "Lost atoms" in text:
        raise EngineError(f"{engine} lost atoms; log: {screen_path}")
    dangerous = sum(int(m) for m in re.findall(r"Dangerous builds\s*=\s*(\d+)", text))
    if dangerous:
        raise EngineError(f"{engine} reported {dangerous} dangerous neighbour-list builds (pairs "
                          "may have been missed): reduce dt or the compression rate, or raise "
                          f"the skin; log: {screen_path}")
    particles = work / "particles.dump"
    tapping = case["protocol"]["name"] == "tapping"
    if engine == "liggghts" and not tapping:  # tapping: no box.dat (the container is fixed)
        restore_box_precision(particles, work / "box.dat", data)
    if body:
        law = ("harmonic" if kind(case) == "2d" else "hooke", float(case["contact"]["k_n"]))
        stats = convert_body_rods(work / "vertices.native", particles, data, law,
                                  work / "contacts.dump", work / "rods.dump",
                                  2 if kind(case) == "2d" else 3)
        os.replace(work / "rods.dump", particles)
    elif glued:
        width = case.get("container", {}).get("width")
        stats = convert_glued_rods(work / "contacts.native", particles, work / "contacts.dump",
                                   work / "rods.dump", None if width is None else float(width))
        os.replace(work / "rods.dump", particles)
    elif multisphere and tapping:
        stats = convert_liggghts_tap(work, case)
        os.replace(work / "rods.dump", particles)
    elif settles(engine, case):
        stats = convert_settled_rods(work / "contacts.native", particles, work / "contacts.dump",
                                     work / "rods.dump")
        os.replace(work / "rods.dump", particles)
    elif multisphere:
        stats = convert_multisphere_rods(work / "contacts.native", particles,
                                         work / "contacts.dump", work / "rods.dump",
                                         float(case["container"]["width"]))
        os.replace(work / "rods.dump", particles)
    else:
        convert = convert_lammps_contacts if engine == "lammps" else convert_liggghts_contacts
        stats = convert(work / "contacts.native", particles, work / "contacts.dump")
    for name in ("particles.dump", "contacts.dump", "thermo.dat"):
        os.replace(work / name, outdir / name)
    for old in work.glob("restart.*"):  # finished: nothing left to resume
        old.unlink()
    steps = _last_step(outdir / "thermo.dat")
    n = _count_atoms(outdir / "particles.dump")
    settled = {}
    if case["protocol"]["name"] == "deposit" or settles(engine, case):
        settled = {"settled": "rodpack: settled at step" in text}
    return {**settled, "engine_version": engine_version(engine, text), "command": cmd, "ranks": ranks,
            "wall_seconds": wall, "steps": steps,
            "particle_steps_per_second": n * steps / wall if wall > 0 else float("nan"),
            "contacts_dropped": stats["dropped"], "status": "ok",
            **({"contact_forces": "reconstructed from the overlaps with the contact law "
                                  "(no per-contact output for LAMMPS body particles)"}
               if body else {}),
            "resumed_from": extra.get("restart_file")}


#: LAMMPS writes a restart file every this many dump intervals
RESTART_DUMPS = 10
#: restart files kept while an engine runs (the newest may be half written, so two
#: complete ones stay); older ones are deleted every PRUNE_SECONDS: a long deposit wrote
#: 140 files, 60 MB, for 150 rods
KEEP_RESTARTS = 3
PRUNE_SECONDS = 10.0


def prune_restarts(work: Path, keep: int = KEEP_RESTARTS) -> list[Path]:
    """Delete all but the ``keep`` newest ``restart.<step>`` files in ``work`` (by step);
    returns the deleted paths."""
    if keep < 1:
        raise ValueError(f"keep must be at least 1 (the newest restart file), got {keep}")
    files = sorted((p for p in work.glob("restart.*") if p.name.split(".")[-1].isdigit()),
                   key=lambda p: int(p.name.split(".")[-1]))
    old = files[:-keep]
    for path in old:
        path.unlink(missing_ok=True)
    return old


def _run_pruning(cmd, screen, work: Path, env: dict, timeout: float):
    """Run ``cmd`` in ``work`` with output to ``screen`` and prune its restart files
    (:func:`prune_restarts`) every :data:`PRUNE_SECONDS` while it runs. Returns the
    finished process, or None when it ran past ``timeout`` seconds (it is stopped, as it is
    on any exception here, by :func:`workflows.stopping.stop_process`)."""
    proc = subprocess.Popen(cmd, stdout=screen, stderr=subprocess.STDOUT, cwd=work, env=env)
    deadline = time.perf_counter() + timeout
    try:
        while True:
            left = deadline - time.perf_counter()
            try:
                proc.wait(timeout=max(min(PRUNE_SECONDS, left), 0.0))
                break
            except subprocess.TimeoutExpired:
                prune_restarts(work)
                if time.perf_counter() >= deadline:
                    stop_process(proc)
                    return None
    except BaseException:
        stop_process(proc)
        raise
    prune_restarts(work)
    return proc


def latest_restart(work: Path) -> Path | None:
    """The newest complete restart file of an interrupted LAMMPS run in ``work``.

    LAMMPS writes ``restart.<step>`` in place, so a run killed while writing leaves the
    newest file short. File sizes say nothing (a restart holds the contact history, which
    shrinks when a tapped packing is in flight), so each candidate, newest first, is read
    back by LAMMPS itself (:func:`restart_is_complete`) and the first that reads is taken.
    """
    return _newest_complete(work, restart_is_complete)


def _newest_complete(work: Path, is_complete) -> Path | None:
    """The newest ``restart.<step>`` in ``work`` that is not empty and that
    ``is_complete(path)`` accepts, newest first, or None."""
    if not work.exists():
        return None
    files = sorted((p for p in work.glob("restart.*") if p.name.split(".")[-1].isdigit()),
                   key=lambda p: int(p.name.split(".")[-1]))
    for path in reversed(files):
        if path.stat().st_size > 0 and is_complete(path):
            return path
    return None


def restart_is_complete(path: Path) -> bool:
    """Whether LAMMPS reads the restart file ``path`` to its end (in a child process: a
    corrupt file may abort the reader)."""
    code = ("import sys, lammps; l = lammps.lammps(cmdargs=['-log', 'none', '-screen', 'none']);"
            "l.command('read_restart ' + sys.argv[1])")
    r = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True,
                       timeout=300)
    return r.returncode == 0


def cut_outputs(work: Path, step: int):
    """Cut a run's outputs back to before ``step`` (frames and rows at or after it are
    written again by the resumed run)."""
    for name in ("particles.dump", "contacts.native", "box.dat"):
        path = work / name
        if not path.exists():
            continue
        lines = path.read_text().splitlines(keepends=True)
        if name == "box.dat":
            keep = [ln for ln in lines if ln.startswith("#") or int(float(ln.split()[0])) < step]
        else:
            keep = []
            k = 0
            while k < len(lines):
                if lines[k].startswith("ITEM: TIMESTEP") and int(lines[k + 1]) >= step:
                    break
                keep.append(lines[k])
                k += 1
        io.atomic_write_text(path, "".join(keep))
    thermo = work / "thermo.dat"
    if thermo.exists():
        rows = thermo.read_text().splitlines(keepends=True)
        keep = [r for r in rows if r.startswith("#") or not r.strip()
                or int(float(r.split()[0])) < step]
        io.atomic_write_text(thermo, "".join(keep))


def write_glued_data(init_path, out_path, case: dict) -> float:
    """Write the rods of an initial configuration as glued equal spheres for LAMMPS
    ``fix rigid/small molecule`` and return the total true rod volume.

    Each rod becomes :func:`glued_spheres` spheres of its diameter, centres evenly spaced
    from one spine end to the other (``atom_style sphere`` atoms plus a ``Molecules``
    section read with ``fix property/atom mol``). Every sphere gets the density that gives
    the rod the mass of the solid spherocylinder, ``rho V_rod / (n pi D^3 / 6)``. Spheres
    are written around the rod centre without wrapping, so LAMMPS sets image flags that
    keep each body whole. 2-D cases (``in.2d.compress``): disks in the plane ``z = 0`` of a
    unit-thick periodic box, atom type 1 for the smallest diameter and 2 for larger ones,
    masses set by the deck; the total true rod *area* is returned.
    """
    from pysim.io import read_particle_data
    from rodcase.files import atomic_write_text

    d = read_particle_data(init_path)
    spacing = case["particles"].get("glued_spacing", 0.25)
    rho = case["particles"].get("density", 1.0)
    two_d = case["particles"].get("dimension", 3) == 2
    rows, mols, vels = [], [], []
    vtot = 0.0
    k = 0
    d_small = float(2.0 * d["radius"].min())
    for i in range(len(d["ids"])):
        dia = 2.0 * d["radius"][i]
        length = d["length"][i]
        ns = glued_spheres(length, dia, spacing)
        if two_d:  # areas; masses are set by the 2-D deck (set density/disc)
            vrod = dia * length + np.pi * dia**2 / 4
            dens = 1.0
        else:
            vrod = np.pi * dia**2 * length / 4 + np.pi * dia**3 / 6
            dens = rho * vrod / (ns * np.pi * dia**3 / 6)
        vtot += vrod
        atype = 2 if two_d and dia > d_small * (1 + 1e-9) else 1
        offsets = np.linspace(-length / 2, length / 2, ns) if ns > 1 else np.zeros(1)
        for sk in offsets:
            k += 1
            p = d["x"][i] + sk * d["axis"][i]
            if two_d:
                p[2] = 0.0
            rows.append(f"{k} {atype} {dia:.16g} {dens:.16g} {p[0]:.16g} {p[1]:.16g} {p[2]:.16g}")
            mols.append(f"{k} {d['ids'][i]}")
            vi = d["v"][i]
            vels.append(f"{k} {vi[0]:.16g} {vi[1]:.16g} {vi[2]:.16g} 0 0 0")
    lo, hi = d["box_lo"].copy(), d["box_lo"] + d["box"]
    if two_d:  # a unit-thick periodic z for LAMMPS' 2-D box
        lo[2], hi[2] = -0.5, 0.5
    head = [f"# rodpack glued-sphere rods ({len(d['ids'])} rods, spacing <= {spacing} D)", "",
            f"{k} atoms", f"{2 if two_d else 1} atom types", ""]
    head += [f"{lo[a]:.16g} {hi[a]:.16g} {ax}lo {ax}hi" for a, ax in enumerate("xyz")]
    text = "\n".join(head + ["", "Atoms # sphere", ""] + rows + ["", "Molecules", ""] + mols)
    if np.any(d["v"] != 0.0):  # every sphere moves with its rod (no initial spin)
        text += "\n\nVelocities\n\n" + "\n".join(vels)
    atomic_write_text(out_path, text + "\n")
    return vtot


#: LAMMPS deposition walls (fix wall/gran ... contacts, dumped as f_<fix>[1..7]), in pysim's
#: order of wall ids -(k + 1): (fix id, axis, at the far side x = W)
GLUED_WALLS = (("wallx", 0, False), ("wallx", 0, True), ("wally", 1, False), ("wally", 1, True),
               ("base", 2, False))


def glued_wall_contacts(frame, table, cols, width: float):
    """Sphere-wall contacts of the LAMMPS deposition deck from its wall fixes' per-atom
    contact arrays (``fix wall/gran ... contacts``: ``f_<fix>[1]`` 1 in contact,
    ``[2..4]`` the wall's force on the sphere, ``[5..7]`` the contact's point on the wall;
    rows of ``table`` in ``frame`` order): one row per touching sphere and wall, ``j`` the
    wall id of :data:`GLUED_WALLS` (pysim's numbering: x = 0, x = W, y = 0, y = W, base;
    the fix ``wallx`` holds both x walls, told apart by the point), normal from the sphere
    to the wall, overlap ``R - distance``, point in the middle of the overlap. Returns a
    :class:`analysis.frame.Contacts`."""
    c = {name: k for k, name in enumerate(cols)}
    walls = []
    for fix, axis, far in GLUED_WALLS:
        flag = table[:, c[f"f_{fix}[1]"]]
        force = table[:, [c[f"f_{fix}[{k}]"] for k in (2, 3, 4)]]
        wall = table[:, [c[f"f_{fix}[{k}]"] for k in (5, 6, 7)]]
        on = np.flatnonzero((flag > 0) & ((wall[:, axis] > 0.5 * width) == far))
        walls.append((on, axis, far, np.abs(wall[on, axis] - frame.x[on, axis]), force[on]))
    return _plane_wall_contacts(frame, walls)


def _plane_wall_contacts(frame, walls):
    """Sphere-wall rows of flat walls: ``walls`` lists, for wall id ``-(k + 1)``, ``(on,
    axis, far, gap, force)``: the touching spheres (indices into ``frame``), the wall's
    axis and side (``far``: at ``x = W``), each sphere's centre distance to the wall and
    the wall's force on it. Normal from the sphere to the wall, overlap ``R - gap``, point
    in the middle of the overlap. Returns a :class:`analysis.frame.Contacts`."""
    from analysis.frame import Contacts

    rows = []
    for w, (on, axis, far, gap, force) in enumerate(walls):
        normal = np.zeros((len(on), 3))
        normal[:, axis] = 1.0 if far else -1.0
        overlap = frame.radius[on] - gap
        point = frame.x[on] + (frame.radius[on] - 0.5 * overlap)[:, None] * normal
        rows.append((frame.ids[on], np.full(len(on), -(w + 1)), point, normal, overlap, force))
    i, j, point, normal, overlap, force = (np.concatenate(x) for x in zip(*rows))
    return Contacts(frame.step, i.astype(np.int64), j.astype(np.int64), point, normal, overlap,
                    force)


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


def _write_glued_frame(fp, fc, spheres, contacts, body):
    """Write one frame of glued spheres as rods (:func:`analysis.contacts.glued_bodies`,
    centres wrapped into a periodic box) and their sphere contacts merged per rod pair
    (:func:`analysis.contacts.merge_glued_contacts`) to the open particle and contact
    files; ``body`` (N,) is each sphere's rod id."""
    from analysis.contacts import glued_bodies, merge_glued_contacts

    rods, _ = glued_bodies(spheres, body)
    merged, _ = merge_glued_contacts(spheres, contacts, body)
    centre = np.where(rods.periodic, rods.box_lo + np.mod(rods.x - rods.box_lo, rods.box), rods.x)
    io.write_particles_frame(fp, spheres.step, rods.box, rods.periodic, rods.ids, rods.types,
                             centre, rods.radius, axis=rods.axis, length=rods.length,
                             box_lo=rods.box_lo)
    rec = np.column_stack([merged.point, merged.normal, merged.overlap, merged.force])
    io.write_contacts_frame(fc, spheres.step, rods.box, rods.periodic,
                            np.column_stack([merged.i, merged.j]), rec, box_lo=rods.box_lo)


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


def _with_walls(pairs, walls):
    """One :class:`analysis.frame.Contacts` of sphere-sphere rows followed by wall rows."""
    from analysis.frame import Contacts

    return Contacts(pairs.step, *(np.concatenate([getattr(pairs, k), getattr(walls, k)])
                                  for k in ("i", "j", "point", "normal", "overlap", "force")))


def _iter_dump(path: Path):
    """Yield ``(step, box_lines, periodic, columns, table)`` of a particle dump."""
    from analysis.io import _blocks

    for step, bounds, periodic, cols, table, _first in _blocks(path, "ITEM: NUMBER OF ATOMS"):
        yield step, bounds, periodic, cols, table


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


def _last_step(thermo: Path) -> int:
    last = 0
    with open(thermo) as fh:
        for line in fh:
            if line.strip() and not line.startswith("#"):
                last = int(float(line.split()[0]))
    return last


def _count_atoms(dump: Path) -> int:
    with open(dump) as fh:
        for line in fh:
            if line.startswith("ITEM: NUMBER OF ATOMS"):
                return int(next(fh))
    return 0


# -- contact tables -----------------------------------------------------------------------------
def _iter_local(path: Path):
    """Yield ``(step, box_lines, columns, table)`` of a LAMMPS-style local dump."""
    with open(path) as fh:
        lines = fh.read().splitlines()
    k = 0
    while k < len(lines):
        if not lines[k].startswith("ITEM: TIMESTEP"):
            k += 1
            continue
        step = int(lines[k + 1])
        n = int(lines[k + 3])
        box_lines = lines[k + 4:k + 8]
        cols = lines[k + 8].split()[2:]
        body = lines[k + 9:k + 9 + n]
        table = np.array([r.split() for r in body], dtype=np.float64).reshape(n, len(cols))
        yield step, box_lines, cols, table
        k += 9 + n


def _particle_frames(path: Path):
    """``{step: (ids, x, radius, box_lo, box)}`` of a particle dump, for conversion."""
    from analysis.io import read_particle_frames  # local import: analysis reads dumps

    return {f.step: f for f in read_particle_frames(path)}


def _geometry(frame, ids_i, ids_j):
    """Normal, overlap and contact point of sphere pairs from a particle frame."""
    index = {int(t): k for k, t in enumerate(frame.ids)}
    a = np.array([index[int(t)] for t in ids_i], dtype=np.int64)
    b = np.array([index[int(t)] for t in ids_j], dtype=np.int64)
    d = frame.x[b] - frame.x[a]
    d = frame.minimum_image(d)
    r = np.linalg.norm(d, axis=1)
    n = d / np.where(r > 0, r, 1.0)[:, None]
    delta = frame.radius[a] + frame.radius[b] - r
    point = frame.x[a] + (frame.radius[a] - 0.5 * delta)[:, None] * n
    return n, delta, point


def _write_converted(native: Path, particles: Path, out: Path, columns_of):
    frames = _particle_frames(particles)
    dropped = 0
    with open(io.part_path(out), "w") as fh:
        for step, _box, cols, table in _iter_local(native):
            if step not in frames:
                raise EngineError(f"{native}: contact frame at step {step} has no particle "
                                  f"frame in {particles}")
            fr = frames[step]
            ids_i, ids_j, force = columns_of(cols, table)
            n, delta, point = _geometry(fr, ids_i, ids_j)
            keep = delta > 0
            dropped += int(np.count_nonzero(~keep))
            rec = np.column_stack([point, n, delta, force])[keep]
            ij = np.column_stack([ids_i, ids_j]).astype(np.int64)[keep]
            io.write_contacts_frame(fh, step, fr.box, fr.periodic, ij, rec, box_lo=fr.box_lo)
    io.finalize(out)
    return {"dropped": dropped}


def convert_lammps_contacts(native: Path, particles: Path, out: Path) -> dict:
    """LAMMPS ``patom1 patom2 dist fx fy fz p1 p2 p3 p10 p11 p12`` -> common table.

    The force on i is the normal part ``(fx, fy, fz)`` plus the tangential part
    ``(p1, p2, p3)`` of pair granular (its documented single() extras).
    """
    def columns_of(cols, t):
        return t[:, 0], t[:, 1], t[:, 3:6] + t[:, 6:9]

    return _write_converted(native, particles, out, columns_of)


def convert_liggghts_contacts(native: Path, particles: Path, out: Path) -> dict:
    """LIGGGHTS ``pos(6) id_i id_j periodic force(3) delta`` -> common table.

    ``force`` is the total contact force on i. Contact points are recomputed from the
    particle frame because LIGGGHTS' own ``contactPoint`` is wrong across periodic
    boundaries.
    """
    def columns_of(cols, t):
        return t[:, 6], t[:, 7], t[:, 9:12]

    return _write_converted(native, particles, out, columns_of)


# -- LAMMPS body rods (2-D, body rounded/polygon) ----------------------------------------------
def write_body_data(init_path, out_path, case: dict) -> float:
    """Write the rods of an initial configuration as LAMMPS body particles and return
    their total area (2-D, ``in.2d.body.compress``) or volume (3-D,
    ``in.rods.body.compress``).

    Each rod is one body: two vertices at the spine ends ``x +- (L/2) u`` (one vertex for
    a sphere or disk) and rounded diameter ``D``. 2-D: ``body rounded/polygon`` of mass
    ``rho A`` with ``rho = RHO_2D`` per area and the lab-frame inertia tensor of the
    stadium lamina (:func:`pysim.state.inertia_2d` about the normal; about the spine
    ``rho (4 A R^3/3 + pi R^4/4)`` with ``A = L/2``; the in-plane perpendicular moment is
    the difference); atom type 1 for the smallest diameter, 2 for larger ones, as
    :func:`write_glued_data`. 3-D: ``body rounded/polyhedron`` (integers ``2 1 0``) of
    mass ``rho V`` with the case's density and the solid spherocylinder's moments
    (:func:`pysim.state.inertia_3d`), one atom type.
    """
    from pysim.io import read_particle_data
    from rodcase.files import atomic_write_text
    from pysim.state import area, inertia_2d, inertia_3d, volume

    two_d = case["particles"].get("dimension", 3) == 2
    d = read_particle_data(init_path)
    n = len(d["ids"])
    r = d["radius"]
    length = d["length"]
    small = float(r.min())
    rho = RHO_2D if two_d else case["particles"].get("density", 1.0)
    atoms, bodies = [], []
    total = 0.0
    for i in range(n):
        u = np.array(d["axis"][i], dtype=float)
        if two_d:
            u[2] = 0.0
        u /= np.linalg.norm(u)
        if two_d:
            measure = float(area(r[i], length[i]))
            i_z = float(inertia_2d(r[i], length[i], rho))
            i_u = rho * (4.0 * (length[i] / 2) * r[i]**3 / 3 + np.pi * r[i]**4 / 4)
            w = np.array([-u[1], u[0], 0.0])
            t = i_u * np.outer(u, u) + (i_z - i_u) * np.outer(w, w)
            t[2, 2] = i_z
        else:
            measure = float(volume(r[i], length[i]))
            i_perp, i_axis = (float(v) for v in inertia_3d(r[i], length[i], rho))
            t = i_perp * np.eye(3) + (i_axis - i_perp) * np.outer(u, u)
        total += measure
        atype = 2 if two_d and r[i] > small * (1 + 1e-9) else 1
        x = d["x"][i]
        z = 0.0 if two_d else x[2]
        atoms.append(f"{d['ids'][i]} {atype} 1 {rho * measure:.16g} {x[0]:.16g} {x[1]:.16g} "
                     f"{z:.16g}")
        ends = [0.5 * length[i] * u, -0.5 * length[i] * u] if length[i] > 0 else [np.zeros(3)]
        coords = " ".join(f"{c:.16g}" for e in ends for c in e)
        inertia = " ".join(f"{v:.16g}" for v in (t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2],
                                                  t[1, 2]))
        ints = str(len(ends)) if two_d else f"{len(ends)} {len(ends) - 1} 0"
        bodies += [f"{d['ids'][i]} {1 if two_d else 3} {6 + 3 * len(ends) + 1}", ints, inertia,
                   coords, f"{2.0 * r[i]:.16g}"]
    lo, hi = d["box_lo"].copy(), d["box_lo"] + d["box"]
    if two_d:
        lo[2], hi[2] = -0.5, 0.5
    style = "rounded/polygon" if two_d else "rounded/polyhedron"
    head = [f"# rodpack rods as body {style} ({n} bodies)", "", f"{n} atoms", f"{n} bodies",
            f"{2 if two_d else 1} atom types", ""]
    head += [f"{lo[a]:.16g} {hi[a]:.16g} {ax}lo {ax}hi" for a, ax in enumerate("xyz")]
    text = "\n".join(head + ["", "Atoms # body", ""] + atoms + ["", "Bodies", ""] + bodies)
    if np.any(d["v"] != 0.0):
        text += "\n\nVelocities\n\n" + "\n".join(
            f"{d['ids'][i]} {d['v'][i][0]:.16g} {d['v'][i][1]:.16g} "
            f"{0.0 if two_d else d['v'][i][2]:.16g} 0 0 0" for i in range(n))
    atomic_write_text(out_path, text + "\n")
    return total


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
