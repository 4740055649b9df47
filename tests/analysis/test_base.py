"""The observable pattern: results refuse to be read early, parameters cannot shadow
results, and run() collects results over frames."""
import numpy as np
import pytest

from analysis.base import NotComputedError
from analysis.contacts import ContactNumber, geometric_contacts
from analysis.jamming import sample_mean
from analysis.order import NematicOrder
from analysis.packing import PackingProfile
from tests.analysis.helpers import cubic, frame_of


def test_results_before_compute_raise_and_names_are_protected():
    prof = PackingProfile(thickness=1.0)
    with pytest.raises(NotComputedError, match="call compute"):
        prof.phi
    with pytest.raises(NotComputedError):
        prof.edges  # a parameter of the same name must not answer for the result
    with pytest.raises(AttributeError, match="result name"):
        prof.phi = 1.0
    assert prof.results == {}


def test_run_collects_results_over_frames():
    frames = []
    for k, spacing in enumerate((1.0, 0.99, 0.98)):
        x = cubic(3, spacing=spacing) + 0.2
        fr = frame_of(x, 0.5, [3 * spacing] * 3)
        fr.step = 100 * k
        frames.append((fr, geometric_contacts(fr, 1e-9)))
    table = ContactNumber(c_min=4).run(frames, ["z", "n_rattlers"])
    assert table.step.tolist() == [0, 100, 200]
    assert table.z.tolist() == [6.0, 6.0, 6.0] and table.n_rattlers.tolist() == [0, 0, 0]
    # frame-only observables take bare frames too
    rods = [frame_of(np.zeros((3, 3)), 0.1, [5.0] * 3, axis=[0, 0, 1.0], length=1.0)] * 2
    assert NematicOrder().run(rods, ["S"]).S.tolist() == [1.0, 1.0]
    with pytest.raises(KeyError, match="no results"):
        NematicOrder().run(rods, ["nope"])


def test_sample_mean():
    m, e = sample_mean([0.64, 0.65, 0.66, np.nan])
    assert m == pytest.approx(0.65) and e == pytest.approx(0.01 / np.sqrt(3))
    m, e = sample_mean([0.64, 0.64], errors=[0.01, 0.01])
    assert e == pytest.approx(np.sqrt(2) * 0.01 / 2)
