"""The command line as users run it: ``python -m reach_addon bake ...`` in a subprocess on
files built from the real rigs; the output opened in Blender and checked by evaluation."""

import hashlib
import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest
import rigs
from test_bake import SKIN_CHAIN, snapshot_keys, world_heads

ROOT = Path(__file__).resolve().parents[2]
CLI_RIGS = ("quaternius", "gomakehuman", "metarig")
REPORT_TASK_KEYS = {"target", "arm", "success", "reason", "method", "sampling_states",
                    "frame_start", "frame_end",
                    "bones_keyed", "search_time_s", "preprocess_time_s", "nodes_searched",
                    "nodes_in_solution", "path_length_arm_lengths",
                    # the hand's figures, as the README's report lists them
                    "max_wrist_turn_deg_per_frame", "max_hand_turn_deg_per_frame",
                    "mean_wrist_bend_deg", "max_wrist_bend_deg", "inserted_frames",
                    "unbounded_hand_turns", "touching_transitions"}


def reach(*argv, timeout=300):
    """``python -m reach_addon ARGV`` from the checkout, as a user runs it."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "reach_addon", *map(str, argv)],
                          capture_output=True, text=True, env=env, timeout=timeout, cwd=ROOT)


@pytest.fixture(scope="module")
def scenes(addon, tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli-scenes")
    out = {}
    for kind in CLI_RIGS:
        path = folder / f"{kind}.blend"
        out[kind] = dict(rigs.save_cli_scene(kind, addon.blender.rig, path), path=path)
    return out


def digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def check_output(kind, scene, output, report):
    """Open the baked file: keys on the arm bones, and on the last frame of each successful
    task the skin chain's wrist is on that task's target."""
    bpy.ops.wm.open_mainfile(filepath=str(output), load_ui=False)
    arm = bpy.data.objects[scene["armature"]]
    keys = snapshot_keys(arm)
    for task in report["tasks"]:
        assert task["bones_keyed"], task
        for bone in task["bones_keyed"]:
            assert any(path.startswith(f'pose.bones["{bone}"]') for path, _i in keys), bone
        if task["success"]:
            bpy.context.scene.frame_set(task["frame_end"])
            wrist = world_heads(arm, SKIN_CHAIN[kind])[2]
            target = np.array(bpy.data.objects[task["target"]].matrix_world.translation)
            assert np.linalg.norm(wrist - target) <= 0.005 * scene["arm_length"], task
    return keys


@pytest.mark.parametrize("kind", CLI_RIGS)
def test_bake_round_trip_on_real_rigs(scenes, tmp_path, kind):
    scene = scenes[kind]
    before = digest(scene["path"])
    out, report_path = tmp_path / "out.blend", tmp_path / "report.json"
    run = reach("bake", scene["path"], "--armature", scene["armature"],
                *[a for t in scene["targets"] for a in ("--target", t)],
                "--arm", "right", "--output", out, "--report", report_path)
    assert run.returncode == 0, run.stdout + run.stderr
    progress = [line for line in run.stdout.splitlines() if line.startswith("[")]
    assert [p.split("]")[0] for p in progress] == ["[1/2", "[2/2"]
    assert digest(scene["path"]) == before, "the input file must not change"

    report = json.loads(report_path.read_text())
    assert {"reach_version", "blender_version", "settings", "tasks"} <= set(report)
    assert report["blender_version"] == bpy.app.version_string
    assert report["settings"]["grid_cells"] == 11
    assert [t["target"] for t in report["tasks"]] == scene["targets"]
    for task in report["tasks"]:
        assert REPORT_TASK_KEYS <= set(task)
        assert task["success"] and task["reason"] is None and task["arm"] == "right"
        # the path's positions are the start and every one the search tested on it
        assert task["nodes_searched"] >= task["nodes_in_solution"] - 1 > 0
        assert task["method"] in ("best-first", "sampling")
    first, second = report["tasks"]
    # each target its own reach from the same pose, baked one after the other
    assert first["frame_start"] == 1, "starts at the file's current frame"
    assert second["frame_start"] > first["frame_end"]
    check_output(kind, scene, out, report)


def test_sequence_reaches_the_targets_in_order(scenes, tmp_path):
    scene = scenes["metarig"]
    out, report_path = tmp_path / "seq.blend", tmp_path / "seq.json"
    run = reach("bake", scene["path"], "--armature", scene["armature"], "--target", "Jar",
                "--target", "Cup", "--task", "sequence", "--frame-start", 10,
                "--output", out, "--report", report_path)
    assert run.returncode == 0, run.stdout + run.stderr
    report = json.loads(report_path.read_text())
    tasks = report["tasks"]
    assert [t["target"] for t in tasks] == ["Jar", "Cup"]
    assert tasks[0]["frame_start"] == 10
    assert tasks[0]["frame_end"] < tasks[1]["frame_end"]
    check_output("metarig", scene, out, report)


def test_exit_status_1_keeps_the_tasks_that_succeeded(scenes, tmp_path):
    scene = scenes["gomakehuman"]
    out, report_path = tmp_path / "out.blend", tmp_path / "r.json"
    run = reach("bake", scene["path"], "--armature", scene["armature"], "--target", "Jar",
                "--target", "Inside", "--arm", "right", "--output", out,
                "--report", report_path)
    assert run.returncode == 1, run.stdout + run.stderr
    report = json.loads(report_path.read_text())
    ok, bad = report["tasks"]
    assert ok["success"] and not bad["success"]
    assert bad["reason"] == "target_in_obstacle" and bad["target"] == "Inside"
    assert "Plate" in bad["message"]
    assert "FAILED" in run.stdout
    check_output("gomakehuman", scene, out, {"tasks": [ok]})


BAD = {
    "missing file": (["bake", "{missing}", "--armature", "A", "--target", "Cup", "--output",
                      "{out}"], "not found"),
    "unknown armature": (["bake", "{scene}", "--armature", "Nobody", "--target", "Cup",
                          "--output", "{out}"], "'Nobody'"),
    "unknown target": (["bake", "{scene}", "--armature", "{armature}", "--target", "Teapot",
                        "--output", "{out}"], "'Teapot'"),
    "not an armature": (["bake", "{scene}", "--armature", "Plate", "--target", "Cup",
                         "--output", "{out}"], "'Plate'"),
    "no output": (["bake", "{scene}", "--armature", "{armature}", "--target", "Cup"],
                  "--output"),
    "output is input": (["bake", "{scene}", "--armature", "{armature}", "--target", "Cup",
                         "--output", "{scene}"], "--in-place"),
    "unknown preset": (["bake", "{scene}", "--armature", "{armature}", "--target", "Cup",
                        "--preset", "Gorilla", "--output", "{out}"], "'Gorilla'"),
    "bad bone flag": (["bake", "{scene}", "--armature", "{armature}", "--target", "Cup",
                       "--bone", "upper_arm_right", "--output", "{out}"], "ROLE=BONE"),
    "unknown bone": (["bake", "{scene}", "--armature", "{armature}", "--target", "Cup",
                      "--bone", "upper_arm_right=Tentacle", "--output", "{out}"], "Tentacle"),
    "bad setting": (["bake", "{scene}", "--armature", "{armature}", "--target", "Cup",
                     "--step", "-1", "--output", "{out}"], "step"),
    "unknown obstacles": (["bake", "{scene}", "--armature", "{armature}", "--target", "Cup",
                           "--obstacles", "Furniture", "--output", "{out}"], "'Furniture'"),
    "not a blend file": (["bake", "{text}", "--armature", "{armature}", "--target", "Cup",
                          "--output", "{out}"], "cannot open"),
    "unknown flag": (["bake", "{scene}", "--armature", "{armature}", "--target", "Cup",
                      "--speed", "3", "--output", "{out}"], "--speed"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_exits_2_with_one_line_and_writes_nothing(scenes, tmp_path, case):
    scene = scenes["metarig"]
    text = tmp_path / "notes.blend"
    text.write_text("not a blend file")
    before = digest(scene["path"])
    names = {"missing": tmp_path / "nowhere.blend", "out": tmp_path / "out.blend",
             "scene": scene["path"], "armature": scene["armature"], "text": text}
    argv, needle = BAD[case]
    argv = [a.format(**names) for a in argv] + ["--report", str(tmp_path / "r.json")]
    run = reach(*argv)
    assert run.returncode == 2, run.stdout + run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("reach: "), run.stderr
    assert needle in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.blend"]
    assert digest(scene["path"]) == before


def test_blender_command_callback_gives_the_same_bake(scenes, addon, tmp_path):
    """``blender -c reach`` calls the function given to ``register_cli_command``; called
    directly here (in this Blender, with the extension enabled) it must bake the same keys
    as ``python -m reach_addon``."""
    scene = scenes["quaternius"]
    argv = ["bake", str(scene["path"]), "--armature", scene["armature"], "--target", "Cup",
            "--frame-start", "5"]
    run = reach(*argv, "--output", tmp_path / "module.blend")
    assert run.returncode == 0, run.stderr
    # The command itself is registered only in the Blender program (there is no ``-c`` in
    # the bpy module), so the installed extension's callback is imported and called here.
    command = importlib.import_module(addon.__name__ + ".cli").blender_command
    assert command(argv + ["--output", str(tmp_path / "command.blend")]) == 0
    keys = {}
    for name in ("module", "command"):
        bpy.ops.wm.open_mainfile(filepath=str(tmp_path / f"{name}.blend"), load_ui=False)
        keys[name] = snapshot_keys(bpy.data.objects[scene["armature"]])
    assert keys["module"] and keys["module"] == keys["command"]


def test_help_does_not_exit_the_host():
    from reach_addon import cli

    assert cli.main(["--help"]) == 0
    assert cli.main(["bake", "--help"]) == 0


def test_render_writes_a_still_with_the_red_trajectory_and_a_video(scenes, tmp_path):
    scene = scenes["metarig"]
    out_dir = tmp_path / "render"
    run = reach("bake", scene["path"], "--armature", scene["armature"], "--target", "Cup",
                "--output", tmp_path / "out.blend", "--report", tmp_path / "r.json",
                "--render", out_dir, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    still, movie = Path(report["renders"]["still"]), Path(report["renders"]["video"])
    assert still.parent == out_dir and movie.suffix == ".mp4"
    assert movie.stat().st_size > 10_000 and movie.read_bytes()[4:8] == b"ftyp"
    image = bpy.data.images.load(str(still))
    w, h = image.size
    px = np.array(image.pixels[:]).reshape(h, w, 4)
    red = (px[..., 0] > 0.6) & (px[..., 1] < 0.25) & (px[..., 2] < 0.25)
    assert red.sum() > 100, "the red trajectory is not in the still"


# --- interrupted runs ----------------------------------------------------------------------

# A search that takes minutes: a step of 4 mm and budgets nothing reaches before SIGTERM.
# a straight best-first search at a fifth of the step, not guided round the plate, with
# budgets it will not reach: it plans for many seconds
LONG_PLAN = ("--step", "0.004", "--node-budget", "200000", "--stall-budget", "200000",
             "--no-guide-when-blocked")


def temp_files(folder):
    return sorted(p.name for p in Path(folder).iterdir()
                  if ".tmp" in p.name or p.name.endswith(("@", ".blend1")))


@pytest.mark.parametrize("mode", ("output", "in-place"))
def test_sigterm_while_planning_writes_nothing(scenes, tmp_path, mode):
    """SIGTERM to ``reach bake`` while it plans: it stops within seconds with one line on
    stderr and status 143 (128 + SIGTERM); no output file and no temporary file exist; the
    input is byte for byte what it was (with --in-place too, where the output is the
    input)."""
    import signal
    import time

    scene = scenes["metarig"]
    source = tmp_path / "in" / "scene.blend"
    source.parent.mkdir()
    source.write_bytes(Path(scene["path"]).read_bytes())
    before = digest(source)
    out = tmp_path / "out" / "baked.blend"
    where = ["--in-place"] if mode == "in-place" else ["--output", out]
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "reach_addon", "bake", str(source), "--armature",
         scene["armature"], "--target", "Cup", *map(str, where), "--report",
         str(tmp_path / "out" / "report.json"), *LONG_PLAN],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    try:
        seen = []
        for line in proc.stdout:                      # Blender's own lines, then ours
            seen.append(line)
            if line.startswith("planning 1 target(s)"):   # printed as planning starts
                break
        assert seen and seen[-1].startswith("planning"), "".join(seen) + proc.stderr.read()
        time.sleep(2.0)
        assert proc.poll() is None, "the plan ended before SIGTERM: make it longer"
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=60)
        stdout = "".join(seen) + stdout
        stopped_in = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + signal.SIGTERM, stdout + stderr
    assert stopped_in < 10.0
    lines = stderr.strip().splitlines()
    assert lines[-1].startswith("reach: stopped by SIGTERM; nothing was written"), stderr
    assert "[1/1]" not in stdout and "saved" not in stdout
    assert digest(source) == before, "the input file changed"
    assert not out.parent.exists() or sorted(p.name for p in out.parent.iterdir()) == []
    assert [p.name for p in source.parent.iterdir()] == ["scene.blend"]


def test_in_place_replaces_the_input_whole_and_leaves_no_backup_or_temporary_file(
        scenes, tmp_path):
    scene = scenes["quaternius"]
    source = tmp_path / "scene.blend"
    source.write_bytes(Path(scene["path"]).read_bytes())
    before = digest(source)
    run = reach("bake", source, "--armature", scene["armature"], "--target", "Jar",
                "--in-place", "--report", tmp_path / "r.json")
    assert run.returncode == 0, run.stdout + run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "scene.blend"]
    assert digest(source) != before
    check_output("quaternius", scene, source, json.loads((tmp_path / "r.json").read_text()))


def test_output_is_replaced_only_whole(scenes, tmp_path):
    """The atomic writers themselves: an existing output is replaced only by a complete
    file; a writer stopped half way (KeyboardInterrupt, as a signal arrives) leaves the old
    file and no temporary file; a saved .blend leaves no ``.blend1`` backup or ``@`` file
    and opens in Blender."""
    from reach_addon import atomic

    dest = tmp_path / "report.json"
    dest.write_text("old")
    with pytest.raises(KeyboardInterrupt):
        with atomic.replacing(dest) as tmp:
            tmp.write_text("half of the new")
            raise KeyboardInterrupt
    assert dest.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]
    atomic.write_text(dest, "new")
    assert dest.read_text() == "new" and sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]

    bpy.ops.wm.open_mainfile(filepath=str(scenes["metarig"]["path"]), load_ui=False)
    blend = tmp_path / "out.blend"
    blend.write_bytes(b"an older file")
    atomic.save_blend(blend)
    atomic.save_blend(blend)                          # over its own complete version too
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.blend", "report.json"]
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    assert scenes["metarig"]["armature"] in bpy.data.objects
