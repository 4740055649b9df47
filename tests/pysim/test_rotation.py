"""The free rotation of symmetric tops: the series sines and cosines, the exact rotation
against SciPy's, and the rods' SIMD-lane path of the Verlet integrator against the one
that turns rod by rod."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pysim.integrators import ROT_BLOCK, _half_and_half, inverses
from pysim.rotation import SERIES_MAX, quaternions_from_axes, rotate_top, sincos


def test_series_sine_and_cosine_are_the_library_values():
    a = np.concatenate([np.linspace(-SERIES_MAX, SERIES_MAX, 4001), [0.0, 1e-300, 3e-8]])
    for ai in a:
        s, c = sincos(ai, True)
        assert abs(s - np.sin(ai)) <= 2 * np.spacing(abs(np.sin(ai))) + 1e-300
        assert abs(c - np.cos(ai)) <= 2 * np.spacing(np.cos(ai))


@pytest.mark.parametrize("angle", [1e-3, 0.9, 3.0])  # within the series, and past it
def test_equal_moments_turn_about_the_angular_momentum_by_its_angle(angle):
    """With I_axis = I_perp the free top turns by |L| dt / I about L, as SciPy's
    rotation vector says, in the series range (half-angle <= SERIES_MAX) and past it."""
    rng = np.random.default_rng(4)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    i_perp, dt = 0.7, 0.01
    L = axis * angle * i_perp / dt
    u = Rotation.from_quat(np.roll(q, -1)).apply([0.0, 0.0, 1.0])
    new = np.array(rotate_top(*q, *L, *u, 1.0 / i_perp, 1.0 / i_perp, dt))
    want = (Rotation.from_rotvec(axis * angle) * Rotation.from_quat(np.roll(q, -1))).as_quat()
    want = np.roll(want, 1)
    want *= np.sign(want[0]) * np.sign(new[0])
    np.testing.assert_allclose(new, want, atol=1e-14)


def _gas(n, seed, dim2=False, wild=False):
    """Rods (every third a sphere) with random orientations, spins and forces; ``wild``
    spins some so fast that a half-angle leaves the series' range."""
    rng = np.random.default_rng(seed)
    half = rng.uniform(0.5, 2.0, n)
    half[::3] = 0.0
    radius = np.full(n, 0.5)
    mass = np.pi * radius**2 * (4.0 / 3.0 * radius + 2.0 * half)
    inertia = np.column_stack([mass * (0.25 + half**2), 0.4 * mass * radius**2])
    inertia[5] = inertia[5, 0]  # equal moments: no spin about the axis
    u = rng.normal(size=(n, 3))
    if dim2:
        u[:, 2] = 0.0
    u /= np.linalg.norm(u, axis=1)[:, None]
    q = quaternions_from_axes(u)
    omega = rng.normal(0, 3.0, (n, 3))
    omega[7] = 0.0  # no angular momentum at all
    if wild:
        omega[1::4] *= 1e4
    a = dict(x=rng.uniform(0, 10, (n, 3)), v=rng.normal(size=(n, 3)), q=q, u=u, omega=omega,
             f=rng.normal(size=(n, 3)), torque=rng.normal(size=(n, 3)), mass=mass,
             inertia=inertia, inv=np.empty((n, 3)), radius=radius, half=half,
             r_int=radius + half)
    inverses(a["mass"], a["inertia"], a["inv"])
    return a


@pytest.mark.parametrize("dim2", [False, True])
@pytest.mark.parametrize("wild", [False, True])
@pytest.mark.parametrize("parts", [1, 3])
@pytest.mark.parametrize("grow", [1.0, 1.001])
def test_rods_on_lanes_take_the_bits_of_the_rod_by_rod_loop(dim2, wild, parts, grow):
    """:func:`_half_and_half` with its rods turned together on SIMD lanes gives the bits
    of the loop that turns them one by one (which :func:`_first_half` and FIRE use too):
    spheres among the rods, a rod without angular momentum, equal moments, half-angles
    past the series (``wild``), 2-D, growth, several parts and a last block cut short."""
    n = 3 * ROT_BLOCK + 17
    box = np.full(3, 10.0)
    periodic = np.array([True, True, not dim2])
    out = []
    for lanes in (True, False):
        a = _gas(n, 11, dim2, wild)
        _half_and_half(a["x"], a["v"], a["q"], a["u"], a["omega"], a["f"], a["torque"],
                       a["mass"], a["inertia"], a["inv"], a["radius"], a["half"], a["r_int"],
                       box, periodic, 5e-4, 1e-3, dim2, np.ones(3), False, grow, grow**3,
                       grow**5, parts, lanes)
        out.append(a)
    for k in out[0]:
        np.testing.assert_array_equal(out[0][k], out[1][k], err_msg=k)
    turned = out[0]["half"] > 0
    assert np.all(np.abs(np.linalg.norm(out[0]["u"][turned], axis=1) - 1.0) < 1e-15)
    if dim2:
        assert np.all(out[0]["u"][:, 2] == 0.0)
