"""The package layering and the no-cycle rule are contracts (pyproject.toml, import-linter), the
code stays clean under ruff's rules (pyproject.toml's [tool.ruff]), and mypy finds no type error in
the packages it checks (pyproject.toml's [tool.mypy])."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from importlinter.cli import lint_imports

ROOT = Path(__file__).resolve().parents[1]


def test_import_contracts_hold(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    code = lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True, no_logo=True)
    report = capsys.readouterr().out
    assert code == 0, report
    assert "0 broken" in report


def test_ruff_finds_nothing():
    done = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", str(ROOT)], capture_output=True,
                          text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr


def test_skills_import_only_the_skill_kit_of_behaviours():
    """`behaviours/` lists skills; what they share is in `behaviours/skill_kit/`, which imports no
    skill, and no skill imports another."""
    wrong = []
    for path in sorted((ROOT / "behaviours").rglob("*.py")):
        if path == ROOT / "behaviours" / "__init__.py":  # it imports every skill to register them
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module] if node.module != "behaviours" else [f"behaviours.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            wrong += [f"{path.relative_to(ROOT)}:{node.lineno} imports {name}" for name in names
                      if name.startswith("behaviours.") and not name.startswith("behaviours.skill_kit")]
    assert not wrong, "\n".join(wrong)


TYPE_CHECKED = ("assembly", "behaviours", "fvfiles")


def test_mypy_finds_nothing():
    """The cache under the repository (mypy ignores it in git) makes a second run take seconds, not a minute."""
    done = subprocess.run([sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"),
                           "--cache-dir", str(ROOT / ".mypy_cache"), *TYPE_CHECKED], cwd=ROOT, capture_output=True,
                          text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
