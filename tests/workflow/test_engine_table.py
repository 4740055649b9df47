"""The adapter table of workflows/engines/table.py: every row's deck is there and is the
one that runs its cases, pysim runs everything, and a combination without a row is
refused in one line naming the engine, shape and protocol and what does run."""
import pytest

from rodcase.case import validate_case
from tests.cases import ENGINE_COMPRESS
from workflows import capabilities, engines
from workflows.engines import table


def test_every_row_names_a_deck_that_exists():
    for (engine, shape, protocol), adapter in table.ADAPTERS.items():
        assert (adapter.engine, adapter.shape, adapter.protocol) == (engine, shape, protocol)
        assert shape in table.SHAPES and protocol in table.PROTOCOLS
        if engine == "pysim":
            assert adapter.deck is None and adapter.resumes
            continue
        assert adapter.deck_path().is_file(), adapter.deck
        assert adapter.deck.split("/")[0] == engine.split("-")[0]  # inputs/<engine>/
        assert adapter.variables and adapter.convert and adapter.command and adapter.version


def test_pysim_has_a_row_for_every_shape_and_protocol():
    assert {(s, p) for e, s, p in table.ADAPTERS if e == "pysim"} == {
        (s, p) for s in table.SHAPES for p in table.PROTOCOLS}
    assert table.ENGINES == ("pysim", "lammps", "lammps-body", "liggghts")
    assert capabilities.ENGINES is table.ENGINES and capabilities.SHAPES is table.SHAPES


def test_the_shipped_cases_run_on_their_rows_deck():
    """deck() is the row's deck and settles() its flag, on every shipped case an engine
    runs."""
    seen = set()
    for case in capabilities.shipped_cases():
        for engine in table.ENGINES[1:]:
            if engines.supports(engine, case) is None:
                adapter = table.lookup(engine, case)
                seen.add((engine, adapter.shape, adapter.protocol))
                assert engines.deck(engine, case) == adapter.deck_path()
                assert engines.settles(engine, case) == adapter.settles
    assert ("lammps", "spheres", "compress") in seen and ("liggghts", "rods", "tapping") in seen


def test_a_missing_combination_is_one_line_naming_what_runs():
    growth = validate_case({**ENGINE_COMPRESS, "protocol": {"name": "growth", "phi_init": 0.3,
                                                 "rate": 1e-3, "phi_grow": 0.5, "dt": 1e-4}})
    msg = engines.supports("liggghts", growth)
    assert msg == ("liggghts has no deck for spheres under protocol 'growth' (it runs compress "
                   "(spheres, rods), tapping (rods), deposit (rods); engines that run spheres "
                   "under 'growth': pysim)")
    with pytest.raises(engines.EngineError, match="no deck for spheres under protocol 'growth'"):
        engines.deck("liggghts", growth)
    with pytest.raises(engines.EngineError, match="no deck for spheres under protocol 'growth'"):
        engines.deck_vars(growth, "lammps")
    assert engines.supports("gromacs", growth) == (
        "unknown engine 'gromacs'; valid: pysim, lammps, lammps-body, liggghts")
