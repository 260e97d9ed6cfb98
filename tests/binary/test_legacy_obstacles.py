"""Every object type and instancing kind in Debian's Blender 3.4.1, headless and in its
interface: the scene of ``tests/blender/obstacle_scene.py`` built by the binary itself
(``scripts/obstacle_types.py``), obstacles gathered several times, a legacy command-line
bake that leaves the input file untouched, and Plan + Bake in the GUI after which Blender
is still running and saves the file."""

import hashlib
import json
import sys
from pathlib import Path

import pytest
from binhost import ROOT, SCRIPTS, output, tagged
from test_legacy_bake import LEGACY_CLI

sys.path.insert(0, str(ROOT / "tests" / "blender"))
import obstacle_scene  # noqa: E402

RIGS = ("quaternius", "metarig")


@pytest.fixture(scope="module")
def scenes(profile):
    """The scene built and gathered by Blender 3.4.1 round two rigs (fresh processes: the
    crash this guards against depended on memory layout)."""
    out = {}
    for rig in RIGS:
        path = profile.root / f"every_type_{rig}.blend"
        proc = profile.blender_run("--background", "--python", SCRIPTS / "obstacle_types.py",
                                   "--", rig, path, timeout=180)
        assert proc.returncode == 0 and path.is_file(), output(proc)
        out[rig] = dict(tagged(proc, "OBSTACLES"), path=path)
    return out


@pytest.mark.parametrize("rig", RIGS)
def test_every_type_gathered_by_blender_34(scenes, rig):
    found = scenes[rig]
    assert found["blender"].startswith("3.4")
    assert found["made"]["Grease pencil"] == "GPENCIL"
    obstacle_scene.check_gathered(found)


def test_legacy_cli_bake_leaves_the_input_untouched(profile, scenes, tmp_path):
    found = scenes["quaternius"]
    path = found["path"]
    before = hashlib.sha256(path.read_bytes()).hexdigest()
    out, report = tmp_path / "baked.blend", tmp_path / "report.json"
    proc = profile.blender_run(
        "--background", path, "--python-expr", LEGACY_CLI, "--", "bake", path,
        "--armature", found["armature"], "--target", found["target"], "--arm", "right",
        "--output", out, "--report", report, timeout=240)
    assert proc.returncode == 0, output(proc)
    r = json.loads(report.read_text())
    assert r["tasks"][0]["success"] and r["baked"] and out.is_file()
    assert [[o["name"], o["triangles"]] for o in r["obstacles"]] == found["runs"][0]
    assert hashlib.sha256(path.read_bytes()).hexdigest() == before


def test_plan_and_bake_in_the_interface_then_save(gui_tools, profile, scenes, tmp_path):
    found = scenes["quaternius"]
    run_dir = tmp_path / "gui"
    proc = profile.blender_run_gui(found["path"], "--python", SCRIPTS / "gui_obstacles.py",
                                   "--", run_dir, found["armature"], found["target"],
                                   timeout=300)
    assert proc.returncode == 0, output(proc)        # a crash is a signal, not 0
    session = json.loads((run_dir / "session.json").read_text())
    assert "error" not in session, session["error"]
    assert session.get("ok") and session["alive_after_save"], output(proc)
    plan, bake = session["steps"]
    for step in (plan, bake):
        assert step["invoked"] == ["RUNNING_MODAL"], step
        task = step["result"]["tasks"][0]
        assert task["success"], task["message"]
        assert [[o["name"], o["triangles"]] for o in step["result"]["obstacles"]] == found["runs"][0]
    assert bake["result"]["baked"]
    # The saved file opens in Blender and holds the baked keys.
    saved = Path(session["saved"])
    dump = tmp_path / "keys.json"
    proc = profile.blender_run("--background", saved, "--python", SCRIPTS / "dump_keys.py", "--",
                               saved, dump, found["armature"], timeout=120)
    assert proc.returncode == 0, output(proc)
    keys = json.loads(dump.read_text())["keys"]
    assert any(k.startswith(f'pose.bones["{b}"]') for k in keys
               for b in bake["result"]["tasks"][0]["bones_keyed"])
