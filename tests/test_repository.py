"""Repository rules that can be checked mechanically."""

import ast
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


def test_lint_is_clean():
    ruff = Path(sys.executable).with_name("ruff")
    result = subprocess.run([str(ruff), "check", "reach_addon", "tests"], cwd=ROOT,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_readme_performance_figures_are_the_bench_results():
    """The README's Performance table is generated from bench/results.json
    (bench/readme.py), so it cannot drift from what make bench measured."""
    done = subprocess.run([sys.executable, str(ROOT / "bench" / "readme.py"), "--check"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, ("README.md's Performance table differs from "
                                  "bench/results.json: run python bench/readme.py " + done.stderr)
