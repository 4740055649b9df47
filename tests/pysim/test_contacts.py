"""The contact kernel against a slow NumPy reference on random dense inputs."""
import numpy as np
import pytest

from pysim.contacts import REC_COLUMNS, sphere_contacts
from pysim.forces import HERTZ, HOOKE
from pysim.neighbors import all_pairs


def reference(x, v, r, box, law, kn, gn):
    """All-pairs NumPy implementation of the same equations."""
    n = len(x)
    f = np.zeros_like(x)
    vir = np.zeros((3, 3))
    pe = 0.0
    nc = 0
    for i in range(n):
        for j in range(i + 1, n):
            d = x[j] - x[i]
            d -= box * np.round(d / box)
            dist = np.linalg.norm(d)
            delta = r[i] + r[j] - dist
            if delta <= 0:
                continue
            nvec = d / dist
            rate = np.dot(v[i] - v[j], nvec)
            fn = kn * (delta if law == HOOKE else delta**1.5) + gn * rate
            f[i] -= fn * nvec
            f[j] += fn * nvec
            vir += np.outer(d, -fn * nvec)
            pe += 0.5 * kn * delta**2 if law == HOOKE else 0.4 * kn * delta**2.5
            nc += 1
    return f, vir, pe, nc


@pytest.mark.parametrize("law", [HOOKE, HERTZ])
def test_kernel_matches_reference(rng, law):
    n = 120
    box = np.full(3, 5.0)
    x = rng.uniform(0, 5.0, (n, 3))
    v = rng.normal(0, 1.0, (n, 3))
    r = rng.uniform(0.35, 0.6, n)
    per = np.ones(3, bool)
    pi, pj = all_pairs(x, r, box, per, 0.3)
    f = np.zeros_like(x)
    vir = np.zeros((3, 3))
    rec_ij = np.empty((len(pi), 2), np.int64)
    rec = np.empty((len(pi), REC_COLUMNS))
    params = np.array([1e4, 3.0])
    pe, nc = sphere_contacts(x, v, r, box, per, pi, pj, law, params, f, vir, True, rec_ij, rec)
    f_ref, vir_ref, pe_ref, nc_ref = reference(x, v, r, box, law, 1e4, 3.0)
    assert nc == nc_ref > 50
    np.testing.assert_allclose(f, f_ref, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(vir, vir_ref, rtol=1e-12, atol=1e-9)
    assert pe == pytest.approx(pe_ref, rel=1e-12)
    # Newton's third law: contact forces sum to zero
    np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-9)
    # the recorded table holds unit normals, positive overlaps, and forces that add up
    rec = rec[:nc]
    np.testing.assert_allclose(np.linalg.norm(rec[:, 3:6], axis=1), 1.0)
    assert np.all(rec[:, 6] > 0)
    f_tab = np.zeros_like(x)
    np.add.at(f_tab, rec_ij[:nc, 0], rec[:, 7:10])
    np.add.at(f_tab, rec_ij[:nc, 1], -rec[:, 7:10])
    np.testing.assert_allclose(f_tab, f, atol=1e-9)
