"""``make demo``'s job (without the renders, which the CLI test covers): the paper's four
tasks on a real character, then two whole-body ones (a cup on the floor, Lean on; then,
stood up again, something on a side table 2.3 arm lengths to her right, reached with a
step), every one reached, baked one after another, and reported."""

import json
import os
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
from test_bake import snapshot_keys

ROOT = Path(__file__).resolve().parents[2]


def test_demo_performs_the_four_tasks_and_two_whole_body_ones(tmp_path):
    run = subprocess.run([sys.executable, "-m", "reach_addon", "demo", "--no-render",
                          "--output", str(tmp_path)], capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=str(ROOT)), cwd=ROOT, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    for name in ("collision_free", "rotation", "guided", "chase", "whole_body", "step"):
        assert any(line.startswith(name) and "reached" in line
                   for line in run.stdout.splitlines()), run.stdout
    assert "paper ms" in run.stdout                        # the Table 2 comparison
    report = json.loads((tmp_path / "report.json").read_text())
    tasks = report["tasks"]
    assert [t["task"] for t in tasks] == ["collision_free", "rotation", "guided", "chase",
                                          "whole_body", "step"]
    body = tasks[-2]["targets"][0]
    assert body["stats"]["lean_deg"] > 45.0, body        # past a standing lean: a bend
    assert "first" in body["message"], body
    step = tasks[-1]["targets"][0]
    assert step["stats"]["step_count"] >= 1 and "stepping" in step["message"], step
    assert all(a["frame_end"] < b["frame_start"] for a, b in zip(tasks, tasks[1:]))
    assert len(tasks[1]["targets"]) == 3

    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "demo.blend"), load_ui=False)
    scene = bpy.context.scene
    arm = next(o for o in scene.objects if o.type == "ARMATURE")
    keys = snapshot_keys(arm)
    assert any('"UpperArm.R"' in path for path, _i in keys)
    shown = {c.name: {o.name.split(" (")[0] for o in c.objects}
             for c in bpy.data.collections if c.name.startswith("Reach ")}
    assert set(shown) == {f"Reach {t['task']}" for t in tasks}   # each task's display kept
    assert "Reach Workspace" in shown["Reach guided"]          # the guiding cells as wire cubes
    assert all("Reach Trajectory" in objects for objects in shown.values())
    for task in tasks:
        for t in task["targets"]:
            scene.frame_set(t["frame_end"])
            hand = arm.pose.bones["LowerArm.R"]
            wrist = np.array(arm.matrix_world @ hand.tail)
            if task["task"] == "chase":
                goal = np.array(bpy.data.objects["Ball"].matrix_world.translation)
            else:
                goal = np.array(bpy.data.objects[t["target"]].matrix_world.translation)
            assert np.linalg.norm(wrist - goal) < 0.01, (task["task"], t["target"])
