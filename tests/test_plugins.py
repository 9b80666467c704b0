"""Skills and scenes from other packages: the example plug-in (examples/fvtree_plugin_example) is
installed into a directory of its own and used by fvtree in a subprocess (so this test session's
tables stay as they are): its skill and scene are listed with their package, in the schema too,
its demo tree runs and its own test of the skill contract passes. A name another package has taken
is a clear error."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

from assembly.language.plugins import PluginError, add_scenes, add_skills
from assembly.testing.skill_checks import CHECKS
from behaviours.skill_kit.base import ProgramSkill

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "fvtree_plugin_example"
TIMEOUT = 600  # generous: two cores shared with other work


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory) -> Path:
    """The example plug-in, installed (with its entry points) into a directory of its own."""
    target = tmp_path_factory.mktemp("plugin")
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--target", str(target), str(EXAMPLE)], check=True, timeout=TIMEOUT,
                   capture_output=True)
    return target


def env_seeing(*paths: Path) -> dict[str, str]:
    """This process's environment, with Python importing from `paths` (fvtree's own root last)."""
    return {**os.environ, "PYTHONPATH": os.pathsep.join([*map(str, paths), str(ROOT)])}


def fvtree(plugin_path: Path, *commands: list[str]) -> list[tuple[int, str]]:
    """(exit code, stdout) of each fvtree command, run in one Python process that sees the plug-in."""
    script = ("import contextlib, io, json, sys\nfrom assembly.cli import main\nout = []\n"
              "for args in json.loads(sys.argv[1]):\n    buf = io.StringIO()\n"
              "    with contextlib.redirect_stdout(buf):\n        code = main(args)\n"
              "    out.append((code, buf.getvalue()))\nprint(json.dumps(out))\n")
    done = subprocess.run([sys.executable, "-c", script, json.dumps(commands)], cwd=ROOT, env=env_seeing(plugin_path),
                          capture_output=True, text=True, timeout=TIMEOUT, check=False)
    assert done.returncode == 0, done.stderr
    return [tuple(r) for r in json.loads(done.stdout.splitlines()[-1])]


def test_the_plugin_skill_and_scene_are_listed_with_their_package(plugin_path):
    (_, skills), (_, table), (_, scenes), (_, schema) = fvtree(
        plugin_path, ["skills", "--json"], ["skills"], ["scenes", "--json"], ["schema"])
    skills, scenes, schema = json.loads(skills), json.loads(scenes), json.loads(schema)
    assert skills["pinch"]["package"] == "fvtree-plugin-example" and skills["move_to"]["package"] == "fvtree"
    assert skills["pinch"]["params"]["squeeze"]["unit"] == "px" and "/task/pinch_width" in skills["pinch"]["writes"]
    assert "pinch: close until the pads feel a squeeze" in table and "[plug-in fvtree-plugin-example]" in table
    assert scenes["light_box"]["package"] == "fvtree-plugin-example"
    assert "extra_load (N, default 0" in scenes["light_box"]["params"]
    pinch = next(v for v in schema["$defs"]["node"]["oneOf"] if v["properties"].get("skill", {}).get("const") == "pinch")
    assert pinch["description"].endswith("[plug-in fvtree-plugin-example]")
    assert "light_box" in schema["properties"]["cell"]["properties"]["scene"]["enum"]


def test_the_plugin_demo_tree_runs(plugin_path, tmp_path):
    [(code, out)] = fvtree(plugin_path, ["run", str(EXAMPLE / "trees" / "pinch.yaml"), "--runs-dir", str(tmp_path),
                                         "--no-plots", "--no-record"])
    assert code == 0, out
    summary = json.loads(next(tmp_path.glob("*/summary.json")).read_text())
    assert summary["status"] == "SUCCESS"
    log = [json.loads(line) for line in next(tmp_path.glob("*/transitions.jsonl")).read_text().splitlines()]
    assert any(e["node"] == "pinch_demo/pinch" and e["to"] == "SUCCESS" and "felt" in e["feedback"] for e in log)


def test_the_plugin_keeps_the_skill_contract(plugin_path):
    """The example's own test (tests/test_pinch_contract.py), run by pytest in the example's folder
    as its author would, with the plug-in installed."""
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"], cwd=EXAMPLE,
                         env=env_seeing(plugin_path), capture_output=True, text=True, timeout=TIMEOUT, check=False)
    assert run.returncode == 0 and f"{len(CHECKS)} passed" in run.stdout, run.stdout + run.stderr


def test_without_the_plugin_its_tree_names_what_is_missing(tmp_path):
    run = subprocess.run([sys.executable, "-m", "assembly.cli", "validate", str(EXAMPLE / "trees" / "pinch.yaml")],
                         cwd=ROOT, env=env_seeing(), capture_output=True, text=True, timeout=TIMEOUT, check=False)
    assert run.returncode == 2 and "no simulated scene 'light_box'" in run.stderr and "unknown skill 'pinch'" in run.stderr


class Impostor(ProgramSkill):
    """A plug-in's skill that takes a name fvtree already has."""

    NAME = "move_to"


def impostor_scene(arm, gripper, args, world, seed):
    """A plug-in's scene builder under a name fvtree already has."""


def test_a_name_clash_is_a_clear_error():
    with pytest.raises(PluginError, match="skill 'move_to' clashes with the skill of that name from package fvtree"):
        add_skills([EntryPoint("move_to", f"{__name__}:Impostor", "fvtree.skills")])
    with pytest.raises(PluginError, match="scene 'hold' clashes with the scene of that name from package fvtree"):
        add_scenes([EntryPoint("hold", f"{__name__}:impostor_scene", "fvtree.scenes")])
    with pytest.raises(PluginError, match="must name a Skill class whose NAME is 'nudge'"):
        add_skills([EntryPoint("nudge", f"{__name__}:Impostor", "fvtree.skills")])
    with pytest.raises(PluginError, match="does not load: ModuleNotFoundError"):
        add_skills([EntryPoint("nudge", "no_such_module:Nudge", "fvtree.skills")])
