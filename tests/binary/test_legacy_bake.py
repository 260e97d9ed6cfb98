"""Reach as a legacy add-on in Debian's Blender 3.4.1, headless: enabled from saved
preferences, baking through the command line documented for Blender ≤ 4.1, and giving the
same keys as the bpy 5.0.1 module on the same file."""

import json
import os
import sys

import numpy as np
from binhost import ROOT, SCRIPTS, output, run, tagged

# The command line the README documents for Blender ≤ 4.1 (no ``blender -c``).
LEGACY_CLI = ("import sys, reach_addon.cli as c; "
              "sys.exit(c.main(sys.argv[sys.argv.index('--') + 1:]))")

PROBE = """
import bpy, json, sys, numpy, reach_addon
print("PROBE " + json.dumps({
    "enabled": "reach_addon" in bpy.context.preferences.addons,
    "module": reach_addon.__file__, "version": list(reach_addon.bl_info["version"]),
    "scene_props": hasattr(bpy.types.Scene, "reach"),
    "panel": hasattr(bpy.types, "REACH_PT_main"),
    "operators": [hasattr(bpy.types, c) for c in ("REACH_OT_plan", "REACH_OT_bake")],
    "cli_command_api": hasattr(bpy.utils, "register_cli_command"),
    "blender": list(bpy.app.version), "numpy": numpy.__version__,
}))
"""


def test_enabled_from_saved_preferences(profile):
    """A new Blender process (no factory settings) comes up with Reach enabled from the
    profile's preferences, its classes registered, on Blender 3.4 and its numpy."""
    proc = profile.blender_run("--background", "--python-expr", PROBE, timeout=60)
    assert proc.returncode == 0, output(proc)
    info = tagged(proc, "PROBE")
    assert info["blender"][:2] == [3, 4]
    assert info["enabled"] and info["scene_props"] and info["panel"] and all(info["operators"])
    assert info["module"] == str(profile.addon_dir / "__init__.py")
    assert not info["cli_command_api"], "3.4 has no register_cli_command: the legacy form is needed"
    assert "Traceback" not in proc.stdout + proc.stderr, output(proc)


def legacy_bake(profile, scene, out_dir, *extra):
    out = out_dir / "baked34.blend"
    report = out_dir / "report34.json"
    proc = profile.blender_run(
        "--background", scene["path"], "--python-expr", LEGACY_CLI, "--",
        "bake", scene["path"], "--armature", scene["armature"], "--target", scene["target"],
        "--output", out, "--report", report, *extra, timeout=180)
    return proc, out, report


def dump(blend, dest, armature, *, binary=None, env=None):
    """Keys and evaluated bone heads of ``blend``, read by the host that is to be checked."""
    if binary is not None:
        proc = binary.blender_run("--background", blend, "--python", SCRIPTS / "dump_keys.py",
                                  "--", blend, dest, armature, timeout=120)
    else:
        proc = run([sys.executable, SCRIPTS / "dump_keys.py", blend, dest, armature],
                   env=env, timeout=120, cwd=ROOT)
    assert proc.returncode == 0 and dest.is_file(), output(proc)
    return json.loads(dest.read_text())


def test_legacy_cli_bake_matches_the_bpy_module(profile, scene, tmp_path):
    """The same scene baked by Blender 3.4.1 (legacy command line) and by bpy 5.0.1
    (``python -m reach_addon``): both succeed, and every key of every baked channel and
    every bone's evaluated position agree on every frame."""
    proc, out34, report34 = legacy_bake(profile, scene, tmp_path)
    assert proc.returncode == 0, output(proc)
    assert out34.is_file() and report34.is_file(), output(proc)
    r34 = json.loads(report34.read_text())

    out50, report50 = tmp_path / "baked50.blend", tmp_path / "report50.json"
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "bpy-user"))
    proc = run([sys.executable, "-m", "reach_addon", "bake", scene["path"],
                "--armature", scene["armature"], "--target", scene["target"],
                "--output", out50, "--report", report50], env=env, timeout=180, cwd=ROOT)
    assert proc.returncode == 0, output(proc)
    r50 = json.loads(report50.read_text())

    assert r34["blender_version"].startswith("3.4") and r50["blender_version"].startswith("5.0")
    for r in (r34, r50):
        assert r["baked"] and len(r["tasks"]) == 1
        task = r["tasks"][0]
        assert task["success"], task["message"]
        assert task["target"] == scene["target"] and task["arm"] == "right"
    t34, t50 = r34["tasks"][0], r50["tasks"][0]
    assert (t34["frame_start"], t34["frame_end"]) == (t50["frame_start"], t50["frame_end"])
    assert t34["bones_keyed"] == t50["bones_keyed"] and len(t34["bones_keyed"]) >= 3
    assert t34["nodes_searched"] == t50["nodes_searched"]

    d34 = dump(out34, tmp_path / "keys34.json", scene["armature"], binary=profile)
    d50 = dump(out50, tmp_path / "keys50.json", scene["armature"], env=env)
    assert d34["blender"].startswith("3.4") and d50["blender"].startswith("5.0")
    assert d34["action"] == d50["action"] == r34["action"]
    assert sorted(d34["keys"]) == sorted(d50["keys"])
    channels = {k.split('"]')[0] for k in d34["keys"]}
    assert channels == {f'pose.bones["{b}' for b in t34["bones_keyed"]}, channels
    f0, f1 = t34["frame_start"], t34["frame_end"]
    assert d34["frame_range"] == [f0, f1]
    for name, keys in d34["keys"].items():
        a, b = np.array(keys), np.array(d50["keys"][name])
        assert a.shape == b.shape == (f1 - f0 + 1, 2), name
        np.testing.assert_array_equal(a[:, 0], np.arange(f0, f1 + 1), err_msg=name)
        np.testing.assert_allclose(a[:, 1], b[:, 1], atol=1e-4, err_msg=name)
    # The keys move the arm: the same evaluated pose in both hosts, frame by frame, and the
    # wrist (the hand bone's head) on the target at the last frame.
    length = scene["arm_length"]
    for f, bones in d34["heads"].items():
        for bone, head in bones.items():
            np.testing.assert_allclose(head, d50["heads"][f][bone], atol=1e-4 * length,
                                       err_msg=f"{bone} at frame {f}")
    hand = t34["bones_keyed"][-1]
    target = np.array(d34["objects"][scene["target"]])
    wrist = {f: np.array(d34["heads"][str(f)][hand]) for f in (f0, f1)}
    assert np.linalg.norm(wrist[f1] - target) <= 0.01 * length
    assert np.linalg.norm(wrist[f0] - target) > 0.3 * length


def test_legacy_cli_bad_input_is_one_line_and_exit_2(profile, scene, tmp_path):
    """On 3.4 too, a wrong armature name is one stderr line naming it, status 2, and no
    file written."""
    proc = profile.blender_run(
        "--background", scene["path"], "--python-expr", LEGACY_CLI, "--",
        "bake", scene["path"], "--armature", "NoSuchRig", "--target", scene["target"],
        "--output", tmp_path / "never.blend", timeout=120)
    assert proc.returncode == 2, output(proc)
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("reach:")]
    assert len(lines) == 1 and "NoSuchRig" in lines[0], output(proc)
    assert not (tmp_path / "never.blend").exists()
