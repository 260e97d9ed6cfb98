"""The paper's four tasks on a sample workplace, with the statistics of Table 2 (and, in
Blender, two whole-body tasks after them, Lean and Look at target on: a cup on the floor,
then something on a side table a step away; the scene: :mod:`.demo_scene`).

:func:`core_demo` uses the core alone (the standard figure, furniture as triangle meshes)
and prints our Table 2 beside the paper's.
"""

from __future__ import annotations

import numpy as np

from .core import Planner, Settings, Task
from . import demo_scene as scene_
from .samples import HANGING, obstacles, shelf, standard_arm, table

#: Table 2 of the paper: search time (s), nodes searched, nodes in solution, path length
#: (arm lengths).
PAPER_TABLE2 = {
    "collision_free": (2.906, 83, 54, 1.07),
    "rotation": (3.172, 157, 149, 2.99),
    "guided": (3.610, 170, 135, 2.69),
    "chase": (10.156, 426, 282, 5.68),
}

#: The workplace in front of the standard figure (world space, metres).
WORKPLACE = {
    "Table": table((-0.25, -0.62), (1.2, 0.5), 0.92),
    "Crate": [((-0.62, -0.37, 0.93), (0.02, -0.31, 1.10))],
    "Shelf": shelf((-0.62, -0.55), 0.5, 0.3, (1.05, 1.38), back_y_sign=-1),
}


#: The demo's whole-body task, after the paper's four: a cup on the floor beside her,
#: (x, y) in the workplace (metres: 0.36 outward of the right shoulder, 0.05 ahead), the
#: wrist ``WHOLE_BODY_ABOVE`` arm lengths over the floor (the issue's squat-or-bend height;
#: more where the hand's capsule needs it), reached with Lean on, the head looking at it.
WHOLE_BODY_AT = (-0.55, -0.05)
WHOLE_BODY_ABOVE = 0.12


def demo_tasks(fps: float = 24.0):
    """The four tasks of the paper's appendix: (name, Task)."""
    t = np.linspace(0.0, 1.0, 96)
    chase = np.stack([-0.12 + 0.18 * np.cos(2 * np.pi * t), -0.46 + 0.06 * np.sin(4 * np.pi * t),
                      1.28 + 0.12 * np.sin(2 * np.pi * t)], 1)
    return [
        ("collision_free", Task("reach", np.array([[-0.28, -0.47, 1.14]]), HANGING, fps,
                                names=("over the crate",))),
        ("rotation", Task("sequence", np.array([[-0.30, -0.45, 1.30], [-0.70, -0.15, 1.35],
                                                 [-0.62, 0.35, 1.35]]), HANGING, fps,
                          names=("front", "side", "behind"))),
        ("guided", Task("guided", np.array([[-0.45, -0.44, 1.22]]), HANGING, fps,
                        names=("in the shelf",))),
        ("chase", Task("chase", chase, HANGING, fps, names=("moving ball",))),
    ]


def core_demo(out) -> int:
    """Plan the four tasks with the core alone and print Table 2 beside the paper's."""
    arm = standard_arm()
    planner = Planner(arm, obstacles(WORKPLACE), Settings())
    rows = []
    for name, task in demo_tasks():
        p = planner.plan(task)
        rows.append((name, p))
        print(f"{name:15s} {'ok' if p.success else 'FAILED: ' + p.message}", file=out)
    print(file=out)
    print(f"{'task':15s} {'search s':>9s} {'paper s':>8s} {'nodes':>6s} {'paper':>6s} "
          f"{'in sol.':>7s} {'paper':>6s} {'length':>7s} {'paper':>6s}", file=out)
    for name, p in rows:
        t, n, k, length = PAPER_TABLE2[name]
        s = p.stats
        print(f"{name:15s} {s.search_time_s:9.3f} {t:8.3f} {s.nodes_searched:6d} {n:6d} "
              f"{s.nodes_in_solution:7d} {k:6d} {s.path_length_arm_lengths:7.2f} {length:6.2f}",
              file=out)
    if planner.has_workspace:
        print(f"\nworkspace preprocessing: {planner.workspace.build_time_s:.3f} s "
              f"(paper: about 6 s)", file=out)
    return 0 if all(p.success for _n, p in rows) else 1


# --- the demo in Blender (its scene: demo_scene.py) -------------------------------------------

GAP = 12          # frames between tasks, in which the arm returns to its start pose


def scene_demo(out_dir, render: bool = True, out=None) -> int:
    """``make demo``: the paper's four tasks on a real character in Blender, then two
    whole-body ones (a cup on the floor beside her, Lean on: :data:`WHOLE_BODY_AT`; stood
    up again, something on a side table a step to her right:
    :func:`.demo_scene.step_target`), baked,
    saved to ``out_dir/demo.blend``, rendered (a still per task with the red trajectory, one MP4)
    unless ``render`` is off, reported (``report.json``) and compared with Table 2; progress
    lines to ``out`` (default stdout). Returns 0 if every task reached, else 1."""
    import sys
    import time
    from pathlib import Path

    import bpy

    from . import __version__
    from .blender import rig as rig_mod

    out = out or sys.stdout
    out_dir = Path(out_dir).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    print(f"Reach {__version__} demo on Blender {bpy.app.version_string}: building the "
          "workplace around Quaternius' Female Casual (CC0)", file=out, flush=True)
    armature = scene_.build_scene(WORKPLACE)
    scene = bpy.context.scene
    frame = 1
    rows, reports, renders = [], [], {}
    bones = rig_mod.build(armature, "right").bones
    arm_bones = {bones.arms["right"].keyed(role)
                 for role in ("clavicle", "upper_arm", "forearm", "hand")}
    rest = scene_.pose_of(armature, ({bones.keyed_chest} | arm_bones) - {None})
    standing = scene_.pose_of(armature, [pb.name for pb in armature.pose.bones])
    outcome = None
    for name, task in demo_tasks(fps=24.0):
        outcome, end, row, report = _demo_task(armature, name, task, frame, out)
        rows.append(row)
        reports.append(report)
        if render:
            from .blender.render import render_outcome

            renders[name] = render_outcome(bpy.context, outcome, out_dir, still=f"{name}.png",
                                           video=None)["still"]
            print(f"{'':15s} rendered {name}.png", file=out, flush=True)
        scene_.keep_display(scene, name)
        scene_.key_pose(armature, rest, end + GAP)
        scene_.rest_body(armature, standing, frame, end, end + GAP)
        frame = end + GAP + 1
    # the whole body: Lean on, a cup on the floor beside her (not in the paper's Table 2),
    # as high over it as her hand's and forearm's capsules let a wrist come
    model = rig_mod.build(armature, "right").arm
    above = max(WHOLE_BODY_ABOVE,
                max(model.hand_radius, model.forearm_radius) / model.arm_length + 0.03)
    floor = above * model.arm_length + scene_.soles(armature)
    cup = Task("reach", np.array([[*WHOLE_BODY_AT, floor]]), HANGING, 24.0,
               names=("on the floor",))
    _outcome, end, body_ok = _body_task(armature, "whole_body", cup, frame, out, out_dir,
                                        render, renders, reports)
    # back to standing, then a step to her right, to the side table
    scene_.stand_up(armature, standing, frame, end)
    frame = end + scene_.BODY_GAP + 1
    scene.frame_set(frame)
    scene_.cut_to(scene.camera, scene_.STEP_CAMERA, frame)
    outcome, end, step_ok = _body_task(armature, "step", scene_.step_target(armature), frame, out,
                                       out_dir, render, renders, reports)
    _finish(armature, outcome, end, out_dir, render, rows, reports, renders, t_start, out)
    return 0 if body_ok and step_ok and all(ok for _n, ok, _s in rows) else 1


def _body_task(armature, name, task, frame, out, out_dir, render, renders, reports):
    """Bake a whole-body task (Lean and Look at target on) from ``frame``, render its still
    (with ``render``), keep its display; returns (outcome, last frame, reached)."""
    import bpy

    outcome, end, (_n, ok, _s), report = _demo_task(
        armature, name, task, frame, out, Settings().replace(lean=True, gaze=True))
    reports.append(report)
    if render:
        from .blender.render import render_outcome

        renders[name] = render_outcome(bpy.context, outcome, out_dir, still=f"{name}.png",
                                       video=None)["still"]
        print(f"{'':15s} rendered {name}.png", file=out, flush=True)
    scene_.keep_display(bpy.context.scene, name)
    return outcome, end, ok


def _demo_target_names(task, frame) -> list:
    """The targets of ``task`` as objects in the scene: a ball keyed along a chase's path
    from ``frame`` on, else an Empty per target. Returns their names."""
    if task.kind == "chase":
        ball = scene_.empty("Ball", task.targets[0], size=0.04)
        for i, p in enumerate(task.targets):
            ball.location = tuple(map(float, p))
            ball.keyframe_insert("location", frame=frame + i)
        return [ball.name]
    return [scene_.empty(f"Target {label}", p).name for label, p in zip(task.names, task.targets)]


def _demo_task(armature, name, task, frame, out, settings=None):
    """Bake one of the demo's tasks from ``frame`` on with the right arm (and ``settings``,
    default the defaults) and print its line; returns (outcome, last frame, Table 2 row
    (name, ok, stats), report entry)."""
    import time

    import bpy

    from .blender import pipeline

    request = pipeline.Request(
        armature=armature.name, targets=_demo_target_names(task, frame), task=task.kind,
        side="right", frame_start=frame, show_guides=(name == "guided"),
        settings=settings or Settings())
    t0 = time.perf_counter()
    outcome = pipeline.run(bpy.context, request, bake=True)
    results = outcome.results
    end = max(r.frame_end for r in results)
    ok = all(r.success for r in results)
    print(f"{name:15s} {'reached' if ok else 'FAILED'}: frames {frame}-{end}, "
          f"{sum(r.stats['nodes_searched'] for r in results)} nodes, "
          f"{time.perf_counter() - t0:.1f} s" +
          ("" if ok else "; " + "; ".join(r.message for r in results if not r.success)),
          file=out, flush=True)
    stats = _demo_stats(results)
    chest = _chest_against_table1(armature, outcome, frame) if name == "rotation" else []
    for c in chest:
        print(f"{'':15s} chest at '{c['target']}': {c['chest_yaw_deg']:5.1f}° "
              f"(Table 1: {c['table1_deg']:5.1f}° at {c['direction_deg']:.0f}°, "
              f"{100 * c['table1_distance_m']:.0f} cm)", file=out, flush=True)
    report = {"task": name, "success": ok, "frame_start": frame, "frame_end": end,
              "targets": [r.to_dict() for r in results], **stats,
              **({"chest_vs_table1": chest} if chest else {})}
    return outcome, end, (name, ok, stats), report


def _demo_stats(results) -> dict:
    """A task's Table 2 statistics summed over its results, and the hand's: its largest
    turn in one frame (relative to the forearm, and in space) and its mean bend over the
    task's frames (degrees)."""
    stats = {k: sum(r.stats[k] for r in results) for k in
             ("search_time_s", "preprocess_time_s", "nodes_searched", "nodes_in_solution",
              "path_length_arm_lengths")}
    for k in ("max_wrist_turn_deg_per_frame", "max_hand_turn_deg_per_frame"):
        stats[k] = max(r.stats[k] for r in results)
    frames = sum(r.stats["frames"] for r in results)
    stats["mean_wrist_bend_deg"] = sum(r.stats["mean_wrist_bend_deg"] * r.stats["frames"]
                                       for r in results) / max(frames, 1)
    stats["max_wrist_bend_deg"] = max(r.stats["max_wrist_bend_deg"] for r in results)
    stats["chicken_wing_frames"] = sum(r.stats.get("chicken_wing_frames", 0) for r in results)
    stats["mean_f_r"] = sum(r.stats["mean_f_r"] * r.stats["frames"]
                            for r in results) / max(frames, 1)
    return stats


def _finish(armature, outcome, last, out_dir, render, rows, reports, renders, t_start, out):
    """Save ``demo.blend`` (frames 1..``last``), render the strip, the MP4 and the envelope
    (with ``render``), write ``report.json`` and print Table 2."""
    import json
    import time

    import bpy

    from . import __version__, atomic

    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, last
    scene.frame_set(1)
    blend = out_dir / "demo.blend"
    atomic.save_blend(blend)
    if render:
        from .blender.render import render_outcome

        renders["strip"] = scene_.strip(out_dir, [r["task"] for r in reports], "demo-strip.png")
        print(f"{'':15s} joined the stills into demo-strip.png", file=out, flush=True)
        print(f"{'':15s} rendering demo.mp4 ({last} frames)", file=out, flush=True)
        renders["video"] = render_outcome(bpy.context, outcome, out_dir, still=None,
                                          video="demo.mp4", frames=(1, last),
                                          size=(480, 270))["video"]
        renders["envelope"] = scene_.envelope_still(armature, out_dir, out)
    report = {"reach_version": __version__, "blender_version": bpy.app.version_string,
              "character": "Quaternius Female Casual (CC0)", "blend": str(blend),
              "tasks": reports, "renders": renders,
              "paper_table2": {k: dict(zip(("search_time_s", "nodes_searched",
                                            "nodes_in_solution", "path_length_arm_lengths"), v))
                               for k, v in PAPER_TABLE2.items()},
              "total_time_s": time.perf_counter() - t_start}
    atomic.write_text(out_dir / "report.json", json.dumps(report, indent=2))
    print(file=out)
    print(table2_text(rows), file=out)
    print(f"\nsaved {blend}, report.json" + (", stills and demo.mp4" if render else "") +
          f" in {out_dir} ({report['total_time_s']:.0f} s)", file=out, flush=True)


def _chest_against_table1(armature, outcome, frame_start):
    """For each reached target of a task: the chest's turn at arrival, read from the
    evaluated bones (:mod:`reach_addon.blender.measure`), beside Table 1's value at the
    wrist's direction and distance as Blender shows them."""
    import bpy

    from .blender import measure
    from .core.torso import chest_rotation_deg, table1_distance

    scene, info = bpy.context.scene, outcome.rig
    bones, side, settings = info.bones, info.side, outcome.request.settings
    scene.frame_set(frame_start)
    axes = measure.body_axes_of(armature, bones)
    reference = measure.bone_matrix(armature, bones.keyed_chest)
    out = []
    for r in outcome.results:
        if not r.success:
            continue
        scene.frame_set(r.frame_end)
        at = measure.arrival(armature, bones, side, axes, reference)
        direction = at["wrist_direction_deg"]
        distance = float(table1_distance(at["wrist_distance"], info.arm.arm_length,
                                         info.arm.hand_length, settings))
        out.append({"target": r.target, "direction_deg": direction,
                    "table1_distance_m": distance, "chest_yaw_deg": at["chest_yaw_deg"],
                    "table1_deg": float(chest_rotation_deg(direction, distance,
                                                           settings.chest_rotation_max))})
    return out


def table2_text(rows) -> str:
    """Table 2, ours beside the paper's: rows of (task, success, stats dict)."""
    lines = [f"{'task':15s} {'search ms':>9s} {'paper ms':>9s} {'speed-up':>8s} {'nodes':>6s} "
             f"{'paper':>6s} {'in sol.':>7s} {'paper':>6s} {'length':>7s} {'paper':>6s} "
             f"{'prep ms':>8s} {'wrist°/fr':>9s} {'hand°/fr':>8s} {'bend°':>6s} {'max°':>5s} "
             f"{'wings':>5s} {'f_R':>5s}"]
    for name, _ok, s in rows:
        t, n, k, length = PAPER_TABLE2[name]
        ms = 1000 * s["search_time_s"]
        lines.append(f"{name:15s} {ms:9.1f} {1000 * t:9.0f} {1000 * t / max(ms, 1e-9):7.0f}× "
                     f"{s['nodes_searched']:6d} {n:6d} {s['nodes_in_solution']:7d} {k:6d} "
                     f"{s['path_length_arm_lengths']:7.2f} {length:6.2f} "
                     f"{1000 * s['preprocess_time_s']:8.1f} "
                     f"{s.get('max_wrist_turn_deg_per_frame', 0.0):9.1f} "
                     f"{s.get('max_hand_turn_deg_per_frame', 0.0):8.1f} "
                     f"{s.get('mean_wrist_bend_deg', 0.0):6.1f} "
                     f"{s.get('max_wrist_bend_deg', 0.0):5.1f} "
                     f"{s.get('chicken_wing_frames', 0):5d} {s.get('mean_f_r', 0.0):5.2f}")
    lines.append("wrist°/fr: the hand's largest turn in one frame relative to the forearm (bound "
                 "15° at 24 fps); hand°/fr: its whole turn in space, the forearm's turn and roll "
                 "included (bound 15°); bend° / max°: the wrist's mean and largest bend from "
                 "the rig's rest alignment, measured on the baked bones; wings: frames with the "
                 "elbow lifted over a low hand (chicken wing); f_R: the mean strength level")
    return "\n".join(lines)
