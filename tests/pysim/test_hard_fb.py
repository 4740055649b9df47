"""The force-biased algorithm (pysim.hard.fb): its forces against a slow NumPy
reference, the densities it reaches, and the fb protocol end to end with resume."""
import json

import numpy as np
import pytest

from pysim.hard.edmd import EDMD
from pysim.hard.fb import FB, cells_per_side, forces
from pysim.hard.start import box_side, poisson
from pysim.initial import sample_diameters, write_initial
from pysim.io import read_particle_data
from pysim.protocols import fb as fb_driver
from rodcase.case import validate_case
from tests.runs import run_case, stopped_and_resumed


def reference_forces(x, dn, side, rho_out):
    """All pairs, minimum image: ``sum_j D_i D_j (1 - d^2 / (rho_out D_ij)^2)`` along
    ``x_i - x_j`` where the outer spheres overlap, and ``min d / D_ij``."""
    dr = x[None, :, :] - x[:, None, :]  # x_j - x_i
    dr -= side * np.round(dr / side)
    d = np.linalg.norm(dr, axis=-1)
    dij = 0.5 * (dn[:, None] + dn[None, :])
    np.fill_diagonal(d, np.inf)
    mag = np.where(d < rho_out * dij, dn[:, None] * dn[None, :] * (1 - (d / (rho_out * dij)) ** 2),
                   0.0)
    return -np.einsum("ij,ijk->ik", mag / d, dr), float(np.min(d / dij))


@pytest.mark.parametrize("sigma", [0.0, 0.2])
def test_forces_match_all_pairs(rng, sigma):
    n = 400
    dn = sample_diameters(n, "lognormal", 1.0, sigma, rng)
    side = box_side(dn, 0.6)
    x = poisson(n, side, rng)
    rho_out = 1.05
    f = np.zeros((n, 3))
    nc = cells_per_side(side, dn, rho_out)
    rho_in = forces(x, dn, side, rho_out, nc, f, np.zeros(n, np.int64),
                    np.zeros(nc**3 + 1, np.int64), np.zeros(n, np.int64))
    want_f, want_in = reference_forces(x, dn, side, rho_out)
    assert np.allclose(f, want_f, rtol=1e-12, atol=1e-12)
    assert rho_in == pytest.approx(want_in, rel=1e-14)


def test_slower_fb_packs_denser_without_overlap(rng):
    """Monodisperse, 500 spheres: the FB density grows as the rate falls (measured
    0.509, 0.607, 0.639 at 1e-2, 1e-3, 1e-4), the run ends with the outer spheres at
    the inner ones, and the inner spheres do not overlap."""
    n = 500
    dn = np.ones(n)
    side = box_side(dn, 0.64)
    x0 = poisson(n, side, rng)
    phis = []
    for rate in (1e-2, 1e-3, 1e-4):
        fb = FB(rate, 0.64)
        a = fb.start(x0, dn, side)
        while not fb.done:
            fb.step(a)
        assert fb.rho_out <= fb.rho_in
        s = EDMD(a["x"], np.zeros((n, 3)), dn, side, 0.0)
        assert s.closest_ratio() == pytest.approx(fb.rho_in, rel=1e-14)
        phis.append(fb.phi())
    assert phis[0] < phis[1] < phis[2]
    assert 0.45 < phis[0] and phis[2] < 0.66


FB_CASE = {"particles": {"n": 200, "diameter": {"distribution": "mono", "mean": 1.0}},
           "protocol": {"name": "fb", "rate": 3e-3, "iterations": 10,
                        "closest_jamming": {"final_rate": 0.3}},
           "output": {"dump_every": 4}, "seed": 5}


def test_fb_then_mls_from_the_command_line(tmp_path):
    out = run_case(tmp_path, FB_CASE)
    meta = json.loads((out / "run.json").read_text())
    assert 0.5 < meta["phi"] < meta["phi_j"] < 0.66
    rows = (out / "blocks.dat").read_text().splitlines()[1:]
    stages = [r.split()[-1] for r in rows]
    n_fb = stages.count("fb")
    assert stages == ["fb"] * n_fb + ["mls"] * (len(rows) - n_fb)
    steps = [int(r.split()[0]) for r in rows]
    assert steps[n_fb - 1] == meta["fb_iterations"] and np.all(np.diff(steps) > 0)
    assert float(rows[n_fb - 1].split()[2]) == pytest.approx(meta["phi"], rel=1e-9)


@pytest.mark.parametrize("stop_in", ["fb", "mls"])
def test_fb_resumes_with_the_same_bytes(tmp_path, monkeypatch, stop_in):
    case = validate_case(FB_CASE)
    write_initial(case, tmp_path / "init.data")
    init = read_particle_data(tmp_path / "init.data")
    full = fb_driver.run(case, init, tmp_path / "full", progress=False)
    from pysim.hard.mls import MLS

    cls = FB if stop_in == "fb" else MLS
    again = stopped_and_resumed(lambda out, **kw: fb_driver.run(case, init, out, **kw),
                                monkeypatch, cls, 5, tmp_path / "full", tmp_path / "cut")
    assert again["phi_j"] == full["phi_j"] and again["phi"] == full["phi"]
