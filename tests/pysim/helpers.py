"""Constructed systems and slow NumPy/SciPy references shared by the pysim tests and the
workflow tests that check pysim's physics: two colliding spheres, random dense rods and
the all-pairs contact reference, overlapping rods for minimisation and normal modes."""
import numpy as np

from pysim.forces import HERTZ, HOOKE, NO_TENSION
from pysim.geometry import segment_closest
from pysim.initial import random_spherocylinders
from pysim.simulation import ContactModel, Simulation
from pysim.state import State


def two_spheres(v0, model, dt):
    """Two spheres of diameter 1 (density 1) just apart along x in a box of side 6,
    each moving towards the other at ``v0``."""
    x = np.array([[2.0, 2.5, 2.5], [3.0 + 1e-9, 2.5, 2.5]])
    st = State.spheres(x, 0.5, np.full(3, 6.0), v=np.array([[v0, 0, 0], [-v0, 0, 0]]))
    return Simulation(st, model, dt=dt)


def collide(sim, nmax):
    """Run until the spheres separate; return (contact duration, relative speed after)."""
    t_in = None
    for _ in range(nmax):
        sim.run(1)
        touching = sim.thermo().n_contacts > 0
        if touching and t_in is None:
            t_in = sim.state.time
        if t_in is not None and not touching:
            v = sim.state.v
            return sim.state.time - t_in, v[1, 0] - v[0, 0]
    raise AssertionError("no separation")


def clipped_restitution(k, gamma, m_eff):
    """Restitution of the linear spring-dashpot clipped at zero force, from the equation
    of motion ``m_eff delta'' = -max(0, k delta + gamma delta')`` (scipy): the contact
    ends when the force reaches zero, before the overlap does."""
    from scipy.integrate import solve_ivp

    def force_zero(t, y):
        return k * y[0] + gamma * y[1] if t > 0 else 1.0
    force_zero.terminal, force_zero.direction = True, -1
    sol = solve_ivp(lambda t, y: [y[1], -(k * y[0] + gamma * y[1]) / m_eff], (0, 1.0),
                    [0.0, 1.0], events=force_zero, rtol=1e-12, atol=1e-14)
    return -sol.y_events[0][0][1]


def random_rods(rng, n, box, lmax, dim=3):
    """``n`` rods at random in ``box`` (a quarter of them spheres): radii 0.35-0.55, spine
    lengths up to ``lmax``, random velocities and spins, in the plane for ``dim`` 2;
    (x, u, r, half, v, w)."""
    x = rng.uniform(0, 1, (n, 3)) * box
    u = rng.normal(size=(n, 3))
    if dim == 2:
        x[:, 2] = 0.0
        u[:, 2] = 0.0
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    r = rng.uniform(0.35, 0.55, n)
    half = rng.uniform(0, lmax / 2, n)
    half[: n // 4] = 0.0  # some spheres among the rods
    v = rng.normal(0, 1, (n, 3))
    w = rng.normal(0, 1, (n, 3))
    if dim == 2:
        v[:, 2] = 0.0
        w[:, :2] = 0.0
    return x, u, r, half, v, w


def reference(x, u, r, half, v, w, box, law, p):
    """Straightforward NumPy transcription of science.md sections 2-3 (frictionless); with
    ``NO_TENSION`` in ``law`` the normal force is clipped at zero. Also returns how many
    contacts were clipped."""
    n = len(x)
    f = np.zeros((n, 3))
    tq = np.zeros((n, 3))
    vir = np.zeros((3, 3))
    pe = 0.0
    nc = clipped = 0
    base = law & (NO_TENSION - 1)
    for i in range(n):
        for j in range(i + 1, n):
            d = x[j] - x[i]
            d -= box * np.round(d / box)
            s, t = segment_closest(np.zeros(3), u[i], half[i], d, u[j], half[j])
            pi_, pj_ = s * u[i], d + t * u[j]
            gap = pj_ - pi_
            dist = np.linalg.norm(gap)
            rs = r[i] + r[j]
            delta = rs - dist
            if delta <= 0:
                continue
            nv = gap / dist
            c = pi_ + (r[i] - delta / 2) * nv
            vrel = (v[i] + np.cross(w[i], c)) - (v[j] + np.cross(w[j], c - d))
            rate = vrel @ nv
            if base == HOOKE:
                fn, e = p[0] * delta, 0.5 * p[0] * delta**2
            elif base == HERTZ:
                fn, e = p[0] * delta**1.5, 0.4 * p[0] * delta**2.5
            else:
                fn, e = p[0] * delta / rs**2, 0.5 * p[0] * (delta / rs) ** 2
            fn += p[1] * rate
            if law & NO_TENSION and fn < 0:
                fn = 0.0
                clipped += 1
            F = -fn * nv
            f[i] += F
            f[j] -= F
            tq[i] += np.cross(c, F)
            tq[j] += np.cross(c - d, -F)
            vir += np.outer(d, F)
            pe += e
            nc += 1
    return f, tq, vir, pe, nc, clipped


def overlapping_rods(dim, n, alpha, phi, seed, spine_contact, k_n=1.0):
    """Rods placed at random without overlap (random sequential addition at half of
    ``phi``), then the periodic box shrunk affinely to ``phi``, well above jamming: they
    overlap. Bidisperse radii 0.5 and 0.7, harmonic law (``k_n``)."""
    rng = np.random.default_rng(seed)
    r = rng.choice([0.5, 0.7], n)
    x, u, r, length, box = random_spherocylinders(r, 2 * alpha * r, phi / 2, seed, dim)
    if dim == 2:
        box[2] = 1.0
    st = State.create(x, r, length, box, axis=u, dimension=dim,
                      periodic=(True, True, dim == 3))
    model = ContactModel("harmonic", k_n, spine_contact=spine_contact)
    sim = Simulation(st, model, dt=0.01, check_dt=False, max_overlap=1.0)
    sim.rescale_box(0.5 ** (1 / dim))
    return sim
