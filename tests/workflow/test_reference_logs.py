"""Every shipped deck has a reference log (inputs/reference_logs/): a file named in that
folder's README.md, named ``log.<version>.<deck>.g++.<ranks>`` (LAMMPS) or
``log.liggghts-<version>.<deck>.<ranks>`` (LIGGGHTS), written by that engine from that
deck. No engine runs here: the logs are read as text."""
import re
from pathlib import Path

import pytest

INPUTS = Path(__file__).resolve().parents[2] / "inputs"
LOGS = INPUTS / "reference_logs"
#: log file name of each engine's folder of decks; group 1 is the deck (``in.<deck>``)
NAME = {"lammps": re.compile(r"^log\.\d{1,2}[A-Z][a-z]{2}\d{4}\.(.+)\.g\+\+\.\d+$"),
        "liggghts": re.compile(r"^log\.liggghts-\d+(?:\.\d+)*\.(.+)\.\d+$")}
#: the first line of a log: the engine's version banner
BANNER = {"lammps": "LAMMPS (", "liggghts": "LIGGGHTS ("}


def named_logs() -> set[str]:
    """Log file names written in the README (``log.`` up to the next blank or backtick)."""
    return set(re.findall(r"\b(log\.[\w.+-]*\w)", (LOGS / "README.md").read_text()))


def decks() -> list[tuple[str, str]]:
    return [(engine, p.name[len("in."):]) for engine in sorted(NAME)
            for p in sorted((INPUTS / engine).glob("in.*"))]


def test_the_decks_are_found():
    found = decks()
    assert ("lammps", "spheres.compress") in found and ("liggghts", "rods.settle") in found


@pytest.mark.parametrize("engine, deck", decks(), ids=lambda x: x)
def test_every_deck_has_a_reference_log(engine, deck):
    logs = sorted(n for n in named_logs()
                  if (m := NAME[engine].match(n)) and m.group(1) == deck)
    assert logs, (f"inputs/{engine}/in.{deck} has no reference log named in "
                  f"inputs/reference_logs/README.md (log.<version>.{deck}...; see its recipe)")
    for name in logs:
        path = LOGS / name
        assert path.is_file(), f"{name} is named in the README but {path} does not exist"
        text = path.read_text(errors="replace")
        assert text.startswith(BANNER[engine]), f"{name} is not a {engine} log"
        # the engines echo the deck, its header comment included
        assert f"# in.{deck} :" in text, f"{name} does not echo the header of in.{deck}"


def test_every_log_in_the_folder_is_named_in_the_readme_and_exists():
    on_disk = {p.name for p in LOGS.glob("log.*")}
    named = named_logs()
    assert named - on_disk == set(), "named in the README but missing"
    assert on_disk - named == set(), "in inputs/reference_logs/ but not named in its README"
