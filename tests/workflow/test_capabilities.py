"""The capability matrix in docs/operations.md is the one the code computes."""
import re
from pathlib import Path

from workflows import capabilities

ROOT = Path(__file__).resolve().parents[2]


def test_the_documented_matrix_is_the_computed_one():
    text = (ROOT / "docs" / "operations.md").read_text()
    block = re.search(r"<!-- capabilities -->\n(.*?)\n<!-- /capabilities -->", text, re.S)
    assert block, "docs/operations.md lost its capabilities block"
    assert block.group(1).strip() == capabilities.markdown(capabilities.matrix()).strip(), (
        "regenerate it: python -m workflows.capabilities")


def test_cells_follow_supports():
    """pysim runs everything; LAMMPS' 2-D deck takes the soft harmonic law only, so its
    2-D compress cell is 'some' over the shipped cases (harmonic and Hookean ones)."""
    cells = capabilities.matrix()
    assert all(v == "yes" for (e, *_), v in cells.items() if e == "pysim")
    assert cells[("lammps", "compress", "rods", True)] == "yes"
    assert cells[("liggghts", "compress", "spheres", False)] == "yes"
    assert ("lammps", "jammed", "rods 2-D", False) in cells
    assert cells[("lammps", "jammed", "rods 2-D", False)] == "no"
