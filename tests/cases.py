"""The small cases that more than one test module runs, and the builders that vary them.
Their values are fixed: tests compare bits and measured numbers against runs of them."""
import copy


def changed(base: dict, **changes) -> dict:
    """A deep copy of ``base`` with ``a__b=value`` set at ``base[a][b]`` (``KeyError``:
    the key removed)."""
    case = copy.deepcopy(base)
    for path, value in changes.items():
        *head, last = path.split("__")
        d = case
        for k in head:
            d = d[k]
        if value is KeyError:
            del d[last]
        else:
            d[last] = value
    return case


# Tapping (science.md section 4) in SI units: 30 glued rods of alpha 2 in a cylinder of
# 8 D, two taps at 30 Hz, Gamma 2; the contact law from e_n 0.4 and t_c 6e-4 s. pysim's
# tapping tests, the LAMMPS/LIGGGHTS tapping decks, the tapping plots and the
# restitution check all run it.
TAP_D = 0.523e-3  # grain diameter (m)
TAP = {
    "particles": {"n": 30, "aspect_ratio": 2.0, "diameter": {"distribution": "mono", "mean": TAP_D},
                  "density": 2500.0, "glued_spacing": 0.5},
    "contact": {"law": "hooke", "restitution": 0.4, "contact_time": 6e-4, "friction": 0.5},
    "container": {"shape": "cylinder", "diameter": 8 * TAP_D},
    "gravity": 9.81,
    "protocol": {"name": "tapping", "dt": 2e-5, "phi_init": 0.15, "settle_time": 0.1,
                 "relax_time": 0.05, "frequency": 30.0, "intensity": 2.0, "taps": 2,
                 "frames_per_tap": 4},
    "output": {"thermo_every": 250},
    "seed": 3,
}

# Deposition under gravity: a random column of 60 frictional Hertz rods (alpha 2) in a
# box of width 6 settling onto its base, for pysim's deposit tests, the initial state,
# the schema and the deposit plot.
DEP = {
    "particles": {"n": 60, "aspect_ratio": 2.0, "diameter": {"distribution": "mono", "mean": 1.0},
                  "density": 1.0, "glued_spacing": 0.5},
    "contact": {"law": "hertz", "k_n": 1e6, "gamma_n": 300.0, "k_t": 1e5, "gamma_t": 100.0,
                "friction": 0.5},
    "container": {"shape": "box", "width": 6.0},
    "gravity": 1.0,
    "protocol": {"name": "deposit", "dt": 1e-4, "phi_init": 0.2, "v_init": 0.5,
                 "ke_ratio": 1e-6, "min_time": 2.0, "max_time": 60.0},
    "output": {"thermo_every": 1000, "dump_every": 20000},
    "seed": 5,
}


def deposit_with(**changes) -> dict:
    """``DEP`` with ``a__b=value`` changes (see :func:`changed`)."""
    return changed(DEP, **changes)


# DEP with 40 rods: the deposition run on the LAMMPS deck (and its limit_damping clip).
DEP_SMALL = deposit_with(particles__n=40)

# The feed (protocol.feed, 2-D): 24 disks entering one at a time at the top of a box of
# width 8, for pysim's feed tests and the schema.
FEED = {
    "particles": {"n": 24, "dimension": 2, "aspect_ratio": 1.0,
                  "diameter": {"distribution": "mono", "mean": 1.0}, "density": 1.0},
    "contact": {"law": "hertz", "k_n": 1e6, "gamma_n": 300.0, "k_t": 1e5, "gamma_t": 100.0,
                "friction": 0.5},
    "container": {"shape": "box", "width": 8.0},
    "gravity": 4.0,
    "protocol": {"name": "deposit", "dt": 2e-4, "ke_ratio": 1e-6, "max_time": 60.0,
                 "feed": {"rate": 2.0, "height": 12.0, "speed": 0.5}},
    "output": {"thermo_every": 500, "dump_every": 2500},
    "seed": 7,
}


def growth_case(n, seed, alpha=0.0, **protocol):
    """A growth case of frictionless hooke particles (the random-packing study's law)."""
    return {"particles": {"n": n, "aspect_ratio": alpha, "diameter": {"mean": 1.0}},
            "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 10.0, "gamma_bg": 0.1},
            "protocol": {"name": "growth", "phi_init": 0.3, "rate": 0.1, "dt": 1e-4,
                         **protocol},
            "output": {"thermo_every": 1000, "dump_every": 5000}, "seed": seed}


# A compression of 200 spheres that pysim runs in seconds, with frames: checkpoints,
# kill -9 / SIGTERM / Ctrl-C and resume, and the runner's failure handling.
PYSIM_COMPRESS = {
    "particles": {"n": 200, "diameter": {"distribution": "mono", "mean": 1.0}},
    "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0},
    "protocol": {"name": "compress", "phi_init": 0.3, "phi_fast": 0.55, "rate_fast": 0.2,
                 "rate": 0.02, "phi_final": 0.68, "dt": 1e-4},
    "output": {"thermo_every": 500, "dump_every": 2000},
    "seed": 9,
}

# A compression of 150 spheres on the LAMMPS and LIGGGHTS decks: the common format and
# its contact tables against the engines' own pressure (and the limit_damping clip).
ENGINE_COMPRESS = {
    "particles": {"n": 150, "diameter": {"distribution": "mono", "mean": 1.0}},
    "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 100.0, "gamma_bg": 1.0},
    "protocol": {"name": "compress", "phi_init": 0.3, "phi_fast": 0.55, "rate_fast": 0.2,
                 "rate": 0.05, "phi_final": 0.68, "dt": 1e-4},
    "output": {"thermo_every": 500, "dump_every": 2000},
    "seed": 4,
}

# LIGGGHTS' random packing of rods (a compression case with a settle block): 60 rods of
# alpha 1 (3 spheres at spacing D/2) in a periodic box of side 5 D under strong gravity:
# a bed about 4.6 D high, settled to 1e-10 of the peak kinetic energy (measured:
# 170,000 steps, 20 s). The settle deck's tests and its limit_damping clip run it.
SETTLE_RODS = {
    "particles": {"n": 200, "aspect_ratio": 1.0, "diameter": {"distribution": "mono", "mean": 1.0},
                  "glued_spacing": 0.5},
    "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0},
    "protocol": {"name": "compress", "phi_init": 0.2, "rate": 0.01, "phi_final": 0.75,
                 "dt": 1e-4,
                 "settle": {"n": 60, "width": 5.0, "gravity": 10.0, "bulk": [0.5, 0.5],
                            "ke_ratio": 1e-10, "max_time": 40.0, "dump_every": 20000}},
    "output": {"thermo_every": 1000},
    "seed": 3,
}
