"""The layers import only downward: rodcase (the case and run record) imports nothing else
of rodpack; pysim (the reference engine) only rodcase; analysis (shared by every engine)
no engine and not the pipeline; workflows anything. No module of the tests imports a test
module (``test_*.py``): shared cases live in tests/cases.py and shared helpers in the
helpers modules, so that a test file runs, and is collected, on its own. Checked on the
source, every import statement, including those inside functions."""
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


def imported_test_modules(path: Path, package: str) -> set[tuple[str, int]]:
    """(module, line) of every import in a file of ``package`` that names a test module
    (a dotted name with a ``test_*`` part), relative imports resolved."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(parts + ([node.module] if node.module else []))
            # 'from tests.pysim import test_tapping' names the module in the alias
            names = [base] if is_test(base) else [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        out |= {(n, node.lineno) for n in names if is_test(n)}
    return out


def is_test(module: str) -> bool:
    return any(part.startswith("test_") for part in module.split("."))


def test_no_test_module_imports_another():
    bad = [f"{p.relative_to(ROOT)}:{line} imports {name}"
           for p in sorted((ROOT / "tests").rglob("*.py"))
           for name, line in sorted(imported_test_modules(
               p, ".".join(p.relative_to(ROOT).parent.parts)))]
    assert not bad, "\n".join(bad)


def test_the_check_sees_every_form_of_importing_a_test_module(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("from tests.pysim.test_tapping import TAP\n"
                 "import tests.workflow.test_engines\n"
                 "from tests.pysim import test_physics\n"
                 "def f():\n    from .test_deposit import DEP\n"
                 "    from .. import test_layers\n"
                 "from tests.cases import TAP\n"
                 "from tests.pysim.helpers import collide\n"
                 "from . import helpers\n")
    assert imported_test_modules(f, "tests.pysim") == {("tests.pysim.test_tapping", 1), ("tests.workflow.test_engines", 2),
                     ("tests.pysim.test_physics", 3), ("tests.pysim.test_deposit", 5),
                     ("tests.test_layers", 6)}
