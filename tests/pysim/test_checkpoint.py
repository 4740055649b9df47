"""Checkpoints: a resumed run is bit-identical to an uninterrupted one."""
import json
import os
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml

from pysim import checkpoint
from pysim.initial import write_initial
from pysim.jit import get_threads, set_threads
from pysim.records import CACHE_DTYPE, PARAMS_DTYPE
from pysim.simulation import ContactModel, Simulation
from pysim.state import State
from rodcase.case import validate_case
from tests.cases import PYSIM_COMPRESS
from tests.pysim.data import make_format1_checkpoints as format1
from tests.runs import pysim_run, start_mid_run


def rods_in_a_tapped_cylinder():
    return format1.scene("rods_tapped", amp=0.05)


def _equal(a, b, err_msg, exact=True):
    """Bit for bit, or within rounding (``exact=False``)."""
    if exact:
        np.testing.assert_array_equal(a, b, err_msg=err_msg)
    else:
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12, err_msg=err_msg)


def assert_same(a: Simulation, b: Simulation, exact=True):
    for k in ("x", "v", "q", "omega", "radius", "mass"):
        _equal(getattr(a.state, k), getattr(b.state, k), k, exact)
    for k in ("f", "torque", "virial", "hist", "whist", "wall_force"):
        _equal(getattr(a, k), getattr(b, k), k, exact)
    assert (a.state.step, a.state.time) == (b.state.step, b.state.time)


def same_bits(a: Simulation, b: Simulation) -> bool:
    """Whether two simulations hold the same state to the bit."""
    try:
        assert_same(a, b)
    except AssertionError:
        return False
    return True


@pytest.mark.parametrize("integrator", ["verlet", "euler"])
def test_resumed_simulation_is_bit_identical(tmp_path, integrator):
    a = rods_in_a_tapped_cylinder()
    a.integrator = integrator
    touching = 0
    springs = 0.0  # the largest pair and wall springs met on the way
    for _ in range(180):
        a.run(100)
        touching += a.thermo().n_contacts + a._nw
        springs = max(springs, min(np.abs(a.whist).max(), np.abs(a.hist).max(initial=0.0)))
    b = rods_in_a_tapped_cylinder()
    b.integrator = integrator
    b.run(3000)
    checkpoint.save(b, tmp_path / "c.npz", extra={"note": "x"})
    b.run(15000)  # the original continues ...
    c, extra = checkpoint.load(tmp_path / "c.npz")  # ... and so does its restart
    assert extra == {"note": "x"}
    assert c.integrator == integrator
    c.run(7000)
    c.run(8000)
    assert touching > 50 and springs > 0
    assert_same(a, b)
    assert_same(a, c)


def test_a_run_returning_at_its_list_rebuilds_is_bit_identical():
    """``verlet_chunk`` returns after each rebuild of a list of ``RETURN_PAIRS`` pairs or
    more (so that ``Simulation.run`` frees the old list) and is called again: a run of
    400 steps with three or more rebuilds gives the same bits as 400 runs of one step."""
    from pysim.initial import random_spheres
    from pysim.integrators import RETURN_PAIRS

    def sim():
        x, d, box = random_spheres(np.ones(4000), 0.3, seed=4)
        st = State.spheres(x, d / 2, box)
        st.v[:] = np.random.default_rng(5).normal(0.0, 15.0, st.v.shape)
        return Simulation(st, ContactModel("hooke", 1e5, 10.0, k_t=5e4, mu=0.5), dt=1e-4,
                          skin=0.5)

    a, b = sim(), sim()
    a.run(1)
    b.run(1)
    assert len(a.pj) >= RETURN_PAIRS
    reb = a.rebuilds
    a.run(400)
    for _ in range(400):
        b.run(1)
    assert a.rebuilds - reb >= 3 and a.rebuilds == b.rebuilds
    assert np.abs(a.hist).max() > 0
    assert_same(a, b)


@pytest.mark.slow
def test_kill_9_and_resume_gives_identical_files(tmp_path):
    case = validate_case(PYSIM_COMPRESS)
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    ref = subprocess.run(pysim_run(cp, tmp_path / "init.data", tmp_path / "ref"),
                         capture_output=True, text=True)
    assert ref.returncode == 0, ref.stderr
    out = tmp_path / "killed"
    proc = start_mid_run(cp, tmp_path / "init.data", out)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not (out / "thermo.dat").exists(), "the run finished before it could be killed"
    again = subprocess.run(pysim_run(cp, tmp_path / "init.data", out, "--resume"),
                           capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    for name in ("particles.dump", "contacts.dump", "thermo.dat"):
        assert (out / name).read_bytes() == (tmp_path / "ref" / name).read_bytes(), name
    assert not (out / "checkpoint.npz").exists()
    assert not list(out.glob("*.part"))


def test_resume_without_checkpoint_is_a_clear_error(tmp_path):
    case = validate_case(PYSIM_COMPRESS)
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    r = subprocess.run(pysim_run(cp, tmp_path / "init.data", tmp_path / "out", "--resume"),
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert "no checkpoint to resume from" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.slow
def test_ctrl_c_stops_with_a_message_and_the_run_resumes(tmp_path):
    """SIGINT (Ctrl-C) mid-run: one line on stderr, no traceback, exit status 130, the
    checkpoint kept; the same command with --resume finishes the run."""
    case = validate_case(PYSIM_COMPRESS)
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    out = tmp_path / "out"
    proc = start_mid_run(cp, tmp_path / "init.data", out)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert not (out / "run.json").exists(), "the run finished before it could be stopped"
    assert proc.returncode == 130, err
    assert "stopped by Ctrl-C" in err and "--resume" in err and "Traceback" not in err
    assert (out / "checkpoint.npz").exists()
    again = subprocess.run(pysim_run(cp, tmp_path / "init.data", out, "--resume"),
                           capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    assert (out / "run.json").exists() and (out / "thermo.dat").exists()


# -- checkpoints of format 1 (the kernels' scalars in one float array of slots) ------------
FORMAT1 = Path(__file__).resolve().parent / "data"


def assert_continued(sim: Simulation, want, exact=True) -> None:
    """``sim`` holds the state that the format-1 code reached (``<scene>_continued.npz``)."""
    for k in format1.CONTINUED:
        _equal(getattr(sim.state, k), want[k], k, exact)
    for k in format1.SIM_CONTINUED:
        _equal(getattr(sim, k), want[k], k, exact)
    assert (sim.state.step, sim.state.time) == tuple(want["clock"])


@pytest.fixture
def one_thread():
    """The format-1 fixtures were written on one thread (the thread count is a
    parameter of the run: ``params.parts``)."""
    before = get_threads()
    set_threads(1)
    yield
    set_threads(before)


@pytest.mark.parametrize("name", sorted(format1.SCENES))
def test_a_format1_checkpoint_resumes_with_the_bits_of_the_code_that_wrote_it(name,
                                                                               one_thread):
    """A checkpoint written by the code of format 1 (tests/pysim/data, with what that code
    reached from it) loads into the records and continues with the same bits, which are
    also those of an uninterrupted run of this code. Bit for bit where this machine's
    kernels compute the writer's bits (an uninterrupted run reaches the checkpoint
    exactly); Numba compiles them for the host processor, whose vector width can change
    the order of a sum, so elsewhere within rounding."""
    with np.load(FORMAT1 / f"{name}.npz") as data:
        assert len(data["sim_sys"]) == len(checkpoint.FORMAT1_SLOTS)
    sim, extra = checkpoint.load(FORMAT1 / f"{name}.npz")
    assert extra == {"scene": name}
    whole = format1.scene(name)
    format1.first_steps(name, whole)
    exact = same_bits(sim, whole)
    assert_same(sim, whole, exact)
    # every slot went to its field (the threads' own flags are not stored: found again)
    assert sim.params.tobytes() == whole.params.tobytes()
    assert sim.cache["own_parts"][0] == 0 and whole.cache["own_parts"][0] == 1
    whole_cache = whole.cache.copy()
    whole_cache["own_parts"] = 0
    assert sim.cache.tobytes() == whole_cache.tobytes()
    assert np.abs(sim.hist).max() > 0
    format1.last_steps(name, sim)
    format1.last_steps(name, whole)
    with np.load(FORMAT1 / f"{name}_continued.npz") as want:
        assert_continued(sim, want)  # the stored state goes on with the writer's bits
        assert_continued(whole, want, exact)
    if name == "rods_tapped":
        assert np.abs(sim.whist).max() > 0


def test_an_earlier_format1_checkpoint_with_fewer_slots_resumes_with_a_new_list(tmp_path,
                                                                               one_thread):
    """Earlier checkpoints of format 1 hold the first slots only (the build state and the
    threads' bookkeeping came later) and no ``u_ref``: the records are completed, a new
    list is built, and the run goes on with the same bits."""
    name = "rods_2d_growing"
    with np.load(FORMAT1 / f"{name}.npz") as data:
        arrays = {k: data[k] for k in data.files if k != "sim_u_ref"}
    arrays["sim_sys"] = arrays["sim_sys"][:14]  # up to the build's largest half-length
    arrays["sim_sys"][[10, 12, 13]] = 0.0  # not yet written by those versions
    np.savez(tmp_path / "old.npz", **arrays)
    sim, _ = checkpoint.load(tmp_path / "old.npz")
    assert sim.params["rods"][0] and sim.params["dim2"][0] and sim.cache["rc_build"][0] > 0
    assert sim.rebuilds == int(json.loads(bytes(arrays["meta"]).decode())["sim"]["rebuilds"])
    format1.last_steps(name, sim)
    with np.load(FORMAT1 / f"{name}_continued.npz") as want:
        assert_continued(sim, want)


def test_a_checkpoint_of_another_format_is_a_clear_error(tmp_path):
    with np.load(FORMAT1 / "rods_tapped.npz") as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(bytes(arrays["meta"]).decode())
    meta["format"] = 7
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    np.savez(tmp_path / "c.npz", **arrays)
    with pytest.raises(ValueError, match=r"checkpoint format 7 is not one of \(1, 2\)"):
        checkpoint.load(tmp_path / "c.npz")


def test_a_checkpoint_stores_the_records_by_field_name(tmp_path):
    """Format 2 stores both records as structured arrays whose fields are the records'
    (read back by name, no pickle)."""
    sim = format1.scene("spheres_compressed")
    sim.run(50, strain_rate=-1.0)
    checkpoint.save(sim, tmp_path / "c.npz")
    with np.load(tmp_path / "c.npz") as data:
        assert "sim_sys" not in data.files
        assert data["sim_params"].dtype.names == sim.params.dtype.names
        assert data["sim_cache"]["rc_build"] == sim.cache["rc_build"] > 0
        np.testing.assert_array_equal(data["sim_params"]["strain_rate"], [[-1.0] * 3])
    back, _ = checkpoint.load(tmp_path / "c.npz")
    assert back.params.tobytes() == sim.params.tobytes()
    for f in sim.cache.dtype.names:  # the threads' own flags are found again
        np.testing.assert_array_equal(back.cache[f], 0 if f == "own_parts" else sim.cache[f])
    assert back.params.dtype == PARAMS_DTYPE and back.cache.dtype == CACHE_DTYPE
    assert back.params.shape == back.cache.shape == (1,)
