"""Repository rules that can be checked mechanically."""

import ast
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_core_never_imports_bpy():
    """The core runs on numpy alone: importing it (and the sample geometry) in a fresh
    interpreter loads no bpy, and no core source mentions it in an import."""
    code = ("import sys; import reach_addon.core, reach_addon.samples; "
            "assert 'bpy' not in sys.modules, 'bpy was imported'")
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, timeout=60)
    for path in (ROOT / "reach_addon" / "core").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            assert not any(n.split(".")[0] == "bpy" for n in names), f"{path.name} imports bpy"


def test_the_extension_never_imports_the_verification():
    """``verification/`` (the refusal cross-check) serves the tests and the benchmarks: no
    module of ``reach_addon`` imports it, so the extension (``reach_addon/`` alone in the
    zip) never needs it."""
    for path in (ROOT / "reach_addon").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            assert not any(n.split(".")[0] == "verification" for n in names), path
    assert (ROOT / "verification" / "__init__.py").exists()


def test_lint_is_clean():
    ruff = Path(sys.executable).with_name("ruff")
    result = subprocess.run([str(ruff), "check", "reach_addon", "tests", "verification", "bench"], cwd=ROOT,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_readme_performance_figures_are_the_bench_results():
    """The README's Performance table is generated from bench/results.json and its fuzz
    counts from bench/fuzz.json (bench/readme.py), so they cannot drift from what make
    bench and make fuzz measured."""
    done = subprocess.run([sys.executable, str(ROOT / "bench" / "readme.py"), "--check"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, ("README.md's Performance table or fuzz counts differ from "
                                  "bench/results.json, bench/fuzz.json: run python "
                                  "bench/readme.py " + done.stderr)

    # and the check can fail: the counts of another campaign are not the README's
    from verification.fuzz.summary import fuzz_counts

    fuzz = json.loads((ROOT / "bench" / "fuzz.json").read_text())
    text = (ROOT / "README.md").read_text()
    assert fuzz_counts(fuzz) in text
    fuzz["passed"] -= 1
    assert fuzz_counts(fuzz) not in text


def _imports(path: Path) -> list:
    """(line, module) of every import in a Python file, wherever it is written; a relative
    import's module is given with its leading dots."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append((node.lineno, "." * node.level + (node.module or "")))
    return out


def test_no_test_imports_the_benchmarks():
    """``bench/`` holds benchmarks only; what the tests use lives in ``verification/`` (or
    the tests' own helpers). No test module imports ``bench`` or one of its modules by name
    (as it could with ``bench/`` put on ``sys.path``)."""
    names = {"bench"} | {f.stem for f in (ROOT / "bench").glob("*.py")} - {"__init__"}
    found = [f"{path.relative_to(ROOT)}:{line}: {module}"
             for path in sorted((ROOT / "tests").rglob("*.py"))
             for line, module in _imports(path)
             if not module.startswith(".") and module.split(".")[0] in names]
    assert not found, "tests import from bench/: " + "; ".join(found)


def test_the_verification_imports_neither_tests_nor_benchmarks_by_name():
    """``verification/`` is imported by ``tests/`` and ``bench/``, never the other way
    round: none of its modules imports ``bench`` or a test module. (It reaches the tests'
    rig builders only through :func:`verification.rig_builders`.)"""
    tests = {f.stem for f in (ROOT / "tests").rglob("*.py")} - {"__init__", "rigs", "synthetic"}
    names = {"bench", "tests"} | {f.stem for f in (ROOT / "bench").glob("*.py")} | tests
    found = [f"{path.relative_to(ROOT)}:{line}: {module}"
             for path in sorted((ROOT / "verification").rglob("*.py"))
             for line, module in _imports(path)
             if not module.startswith(".") and module.split(".")[0] in names - {"__init__"}]
    assert not found, found


def _import_cycles(*args):
    return subprocess.run([sys.executable, str(ROOT / "tools" / "import_cycles.py"), *args],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)


#: The most lines a module, and a function or method, of the extension may have: a module
#: that grows past it does two jobs, a function past it wants named steps (CONTRIBUTING).
MODULE_LINES, FUNCTION_LINES = 600, 80


def test_modules_and_functions_stay_small():
    long_modules, long_functions = [], []
    for path in sorted((ROOT / "reach_addon").rglob("*.py")):
        text = path.read_text()
        name = path.relative_to(ROOT)
        if text.count("\n") > MODULE_LINES:
            long_modules.append(f"{name}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > FUNCTION_LINES:
                    long_functions.append(f"{name}:{node.lineno} {node.name}: {length} lines")
    assert not long_modules, long_modules
    assert not long_functions, long_functions


def test_reach_has_no_import_cycles():
    """tools/import_cycles.py (run by make test too) finds no cycle in reach_addon."""
    done = _import_cycles()
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.strip() == "no import cycles"


def test_the_verification_has_no_import_cycles():
    done = _import_cycles(str(ROOT / "verification"))
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.strip() == "no import cycles"


def _package(root, files):
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root


def test_the_import_cycle_check_finds_a_cycle(tmp_path):
    """A cycle through a function-level import, written with ``from . import x`` (x a
    submodule), fails the check and is named with the lines that make it."""
    pkg = _package(tmp_path / "pkg", {
        "__init__.py": "",
        "a.py": "from .b import helper\n",
        "sub/__init__.py": "",
        "sub/c.py": "import pkg.b\n",
        "b.py": "def helper():\n    from . import a\n    from .sub import c\n",
    })
    done = _import_cycles(str(pkg))
    assert done.returncode == 1, done.stdout + done.stderr
    assert "import cycle: pkg.a, pkg.b, pkg.sub.c\n" in done.stdout
    assert "pkg.b imports pkg.a  (pkg/b.py: line 2)" in done.stdout
    assert "pkg.sub.c imports pkg.b  (pkg/sub/c.py: line 1)" in done.stdout


def test_the_import_cycle_check_on_imports_from_the_own_package(tmp_path):
    """A submodule reading a name from its own package is a cycle only when the package's
    ``__init__`` imports that submodule at module level (the one case in which it can see
    the package half-made); a package importing a submodule's name inside a function is not."""
    files = {"__init__.py": "VERSION = 1\n\ndef register():\n    from .cli import main\n",
             "cli.py": "def main():\n    from . import VERSION\n"}
    done = _import_cycles(str(_package(tmp_path / "late", files)))
    assert done.returncode == 0, done.stdout
    files["__init__.py"] = "from .cli import main\nVERSION = 1\n"
    done = _import_cycles(str(_package(tmp_path / "early", files)))
    assert done.returncode == 1, done.stdout
    assert "import cycle: early, early.cli" in done.stdout
