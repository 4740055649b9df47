"""The layers import only downward: rodcase (the case and run record) imports nothing else
of rodpack; pysim (the reference engine) only rodcase; analysis (shared by every engine)
no engine and not the pipeline; workflows anything. Checked on the source, every import
statement, including those inside functions."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
OURS = {"rodcase", "pysim", "analysis", "workflows", "tests"}
ALLOWED = {
    "rodcase": {"rodcase"},
    "pysim": {"pysim", "rodcase"},
    "analysis": {"analysis", "rodcase"},
}


def imported_packages(path: Path) -> set[tuple[str, int]]:
    """(top-level package of ours, line) of every import in a file."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        out |= {(n.split(".")[0], node.lineno) for n in names if n.split(".")[0] in OURS}
    return out


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_layers_import_only_downward(package):
    bad = [f"{p.relative_to(ROOT)}:{line} imports {top}"
           for p in sorted((ROOT / package).rglob("*.py"))
           for top, line in sorted(imported_packages(p)) if top not in ALLOWED[package]]
    assert not bad, "\n".join(bad)


def test_the_check_sees_imports_inside_functions(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def f():\n    from workflows.studies import runs\n    import analysis.io\n")
    assert imported_packages(f) == {("workflows", 2), ("analysis", 3)}
