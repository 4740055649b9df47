"""The written random starts (:func:`pysim.initial.write_initial`): large ones sorted by
cell, small ones in insertion order, the same particles either way."""
import copy

import numpy as np
import pytest

from pysim import initial
from pysim.io import read_particle_data
from pysim.neighbors import spatial_order
from tests.cases import DEP, growth_case
from rodcase.case import validate_case


@pytest.mark.parametrize("name, dim", [("spheres", 3), ("rods", 3), ("column", 3),
                                       ("column", 2)])
def test_starts_from_sort_min_particles_on_are_sorted_by_cell(tmp_path, monkeypatch, name,
                                                               dim):
    if name == "column":  # rods in a box, with random velocities
        case = copy.deepcopy(DEP)
        case["particles"]["dimension"] = dim
    else:
        case = growth_case(300, 3, alpha=2.0 if name == "rods" else 0.0, phi_grow=0.5,
                           phi_max=0.6, increment=0.01)
        case["particles"]["diameter"] = {"distribution": "lognormal", "mean": 1.0,
                                         "sigma": 0.1}
    case = validate_case(case)
    n = case["particles"]["n"]
    initial.write_initial(case, tmp_path / "insertion.data")
    monkeypatch.setattr(initial, "SORT_MIN", n)
    initial.write_initial(case, tmp_path / "sorted.data")
    a = read_particle_data(tmp_path / "insertion.data")
    b = read_particle_data(tmp_path / "sorted.data")
    np.testing.assert_array_equal(a["box"], b["box"])
    np.testing.assert_array_equal(a["box_lo"], b["box_lo"])
    order = spatial_order(a["x"] - a["box_lo"], a["box"])
    assert not np.array_equal(order, np.arange(n))  # insertion order is not by cell
    np.testing.assert_array_equal(spatial_order(b["x"] - b["box_lo"], b["box"]), np.arange(n))
    for key in ("x", "radius", "length", "axis", "v"):  # the same particles, permuted
        np.testing.assert_array_equal(b[key], a[key][order], err_msg=key)
