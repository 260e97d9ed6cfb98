"""Every Blender object type and every kind of instancing in the scene, round real rigs
(``obstacle_scene.py``): gathering obstacles does not crash, uses exactly the objects with
faces, reaches round a text, a metaball and unrealized geometry-nodes cubes, and a command-
line bake leaves the input file as it was. A mirrored character (scale −1 on X) reaches
with either arm.

Gathering once crashed Blender (SIGSEGV) depending on memory layout: it runs here in fresh
processes, several times each, with a timeout."""

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import bpy
import clearance
import numpy as np
import obstacle_scene
import pytest
import rigs
from geometry import segment_crosses
from test_bake import SKIN_CHAIN, world_heads

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "tests" / "binary" / "scripts" / "obstacle_types.py"
PROCESSES = 3


def run_script(rig, out, timeout=240):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(SCRIPT), rig, str(out)], capture_output=True,
                          text=True, env=env, timeout=timeout, cwd=ROOT)
    assert proc.returncode == 0, f"exit {proc.returncode}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("OBSTACLES "))
    return json.loads(line[len("OBSTACLES "):])


@pytest.fixture(scope="module")
def every_type_file(tmp_path_factory):
    """The scene built and gathered in fresh processes (several: the crash depended on
    memory layout), round two rigs; the last file is kept for the command line."""
    folder = tmp_path_factory.mktemp("every-type")
    for k in range(PROCESSES):
        rig = ("quaternius", "metarig")[k % 2]
        found = run_script(rig, folder / f"scene{k}.blend")
        obstacle_scene.check_gathered(found)
    return folder / f"scene{PROCESSES - 1}.blend", found


def test_every_type_is_used_or_skipped_without_a_crash(every_type_file):
    _path, found = every_type_file
    assert found["blender"] == bpy.app.version_string


def test_cli_bake_in_the_every_type_scene_leaves_the_input_untouched(every_type_file, tmp_path):
    path, found = every_type_file
    before = hashlib.sha256(path.read_bytes()).hexdigest()
    for k in range(2):
        out, report = tmp_path / f"out{k}.blend", tmp_path / f"report{k}.json"
        env = dict(os.environ, PYTHONPATH=str(ROOT),
                   BLENDER_USER_RESOURCES=str(tmp_path / "user"))
        proc = subprocess.run(
            [sys.executable, "-m", "reach_addon", "bake", str(path), "--armature",
             found["armature"], "--target", found["target"], "--arm", "right",
             "--output", str(out), "--report", str(report)],
            capture_output=True, text=True, env=env, timeout=300, cwd=ROOT)
        assert proc.returncode == 0, f"{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
        r = json.loads(report.read_text())
        assert r["tasks"][0]["success"] and r["baked"] and out.is_file()
        assert [[o["name"], o["triangles"]] for o in r["obstacles"]] == found["runs"][0]
        assert hashlib.sha256(path.read_bytes()).hexdigest() == before


BLOCKERS = {"text": "quaternius", "metaball": "gomakehuman", "cubes": "metarig"}


@pytest.mark.parametrize("kind", sorted(BLOCKERS))
def test_reach_goes_round_a_text_a_metaball_and_instanced_cubes(fresh, addon, kind):
    """The blocker lies across the straight path from the wrist to the target (checked on
    Blender's own evaluated triangles); the bake reaches the target and the arm's capsules
    (upper arm, forearm, hand) keep clear of those triangles by their radii at every
    instant; the result lists the blocker as an obstacle."""
    rig = BLOCKERS[kind]
    arm = rigs.load(rig)
    rigs.rest_still(arm)
    info = addon.blender.rig.build(arm, "right")
    f, length = info.frame, info.arm.arm_length
    shoulder, wrist = info.joints_world["shoulder"], info.joints_world["wrist"]
    target = rigs.add_target("Cup", shoulder + length * (0.7 * f.forward + 0.15 * f.right
                                                         + 0.05 * f.up))
    blocker = obstacle_scene.blocker(kind, info, np.array(target.location), wrist)
    tris = obstacle_scene.evaluated_triangles(blocker)
    assert len(tris) and segment_crosses(wrist, np.array(target.location), tris), \
        f"the {kind} must block the straight path"

    props = bpy.context.scene.reach
    props.armature, props.target, props.arm = arm, target, "RIGHT"
    assert bpy.ops.reach.bake() == {"FINISHED"}
    res = json.loads(props.last_result)
    task = res["tasks"][0]
    assert task["success"], task["message"]
    assert [o["name"] for o in res["obstacles"]] == ["Blocker"]
    assert res["obstacles"][0]["triangles"] == len(tris)
    assert f"  Blocker: {len(tris)}" in addon.ui.operators.result_lines(props)

    chain = SKIN_CHAIN[rig]
    capsules = clearance.Arm(arm, info, chain)
    capsules.check_instants(tris, range(task["frame_start"], task["frame_end"] + 1), f"{kind}: ")
    print(f"{kind}: worst margins (arm lengths): {capsules.report()}")
    bpy.context.scene.frame_set(task["frame_end"])
    w = world_heads(arm, chain)[2]
    assert np.linalg.norm(w - np.array(target.location)) <= 0.005 * length


# --- a mirrored character -----------------------------------------------------------------

MIRROR = np.diag([-1.0, 1.0, 1.0, 1.0])


@pytest.mark.parametrize("side", ["right", "left"])
def test_mirrored_character_reaches_with_either_arm(fresh, addon, side):
    """Quaternius' character mirrored through the world's YZ plane (its armature's object
    scale −1 on X, the skin following as a child): the same reach as the original, mirrored,
    is planned and baked — the target 0.66 arm lengths in front of the shoulder behind a
    plate — and every frame's arm is the mirror image of the original's."""
    from mathutils import Matrix

    def bake(mirrored):
        arm = rigs.load("quaternius")
        rigs.rest_still(arm)
        if mirrored:
            arm.matrix_world = Matrix((MIRROR @ np.array(arm.matrix_world)).tolist())
            bpy.context.view_layer.update()
            assert np.linalg.det(np.array(arm.matrix_world)[:3, :3]) < 0
        info = addon.blender.rig.build(arm, side)
        f, length = info.frame, info.arm.arm_length
        out = 1.0 if side == "right" else -1.0
        target = info.joints_world["shoulder"] + length * (0.6 * f.forward + 0.2 * out * f.right
                                                           + 0.05 * f.up)
        cup = rigs.add_target("Cup", target)
        wrist = info.joints_world["wrist"]
        rigs.add_box("Plate", wrist + 0.5 * (target - wrist), (0.3 * length, 0.3 * length,
                                                                0.03 * length))
        props = bpy.context.scene.reach
        props.armature, props.target, props.arm = arm, cup, side.upper()
        assert bpy.ops.reach.bake() == {"FINISHED"}
        task = json.loads(props.last_result)["tasks"][0]
        assert task["success"], task["message"]
        chain = [info.bones.arms[side].upper_arm, info.bones.arms[side].forearm,
                 info.bones.arms[side].hand]
        frames = []
        for frame in range(task["frame_start"], task["frame_end"] + 1):
            bpy.context.scene.frame_set(frame)
            frames.append(world_heads(arm, chain))
        return info, np.array(frames), target

    info0, original, target0 = bake(False)
    info1, mirrored, target1 = bake(True)
    length = info0.arm.arm_length
    assert np.linalg.norm(target1 - MIRROR[:3, :3] @ target0) < 1e-6 * length
    assert info1.frame.forward @ info0.frame.forward > 0.999, "a mirror does not turn the body"
    dist = np.linalg.norm(mirrored[-1, 2] - target1)
    assert dist <= 0.005 * length
    assert np.linalg.norm(target1 - info1.joints_world["shoulder"]) >= 0.6 * length
    assert mirrored.shape == original.shape
    np.testing.assert_allclose(mirrored, original @ MIRROR[:3, :3], atol=0.01 * length)
