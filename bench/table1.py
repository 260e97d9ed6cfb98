"""Table 1 on baked motion: the chest rotation a figure arrives with, against the paper.

:func:`sweep` bakes one reach per (direction, Table 1 row) on an armature in the current
scene, each from the same start pose, and reads back from Blender's evaluated bones
(:mod:`reach_addon.blender.measure`, no planner code) the wrist's direction and distance
from the spine axis and the chest's turn about the vertical at arrival. The targets are
placed in the figure's own body frame at the wrist distance that maps to each row (the
table's reach distance is measured to the hand and scaled by arm length: see
:mod:`reach_addon.core.torso`).

``make bench`` runs :func:`main` on the demo character and writes ``bench/table1.png``:
Table 1's two lines and the baked chest rotations as points. The tests
(``tests/blender/test_table1.py``) run the same sweep on the standard synthetic adult and a
real rig and hold every point to Table 1 within 2°.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Directions of the sweep (degrees from straight ahead toward the reaching side).
DIRECTIONS = tuple(range(30, 166, 15))
#: Table 1's rows (m).
ROWS = (0.75, 0.85)
#: Height of the targets below the shoulders, in arm lengths.
DROP = 0.15


def sweep(context, armature, package, directions=DIRECTIONS, rows=ROWS, side="right",
          settings=None, drop=DROP):
    """Bake a reach to each (row, direction) and measure the arrival (see the module
    docstring). ``package`` is the add-on's package (``reach_addon``, or the installed
    extension's in the tests). Returns one dict per reach."""
    import importlib

    import bpy

    def module(name):
        return importlib.import_module(f"{package.__name__}.{name}")

    measure, pipeline, rig = (module(f"blender.{m}") for m in ("measure", "pipeline", "rig"))
    table1_distance = module("core.torso").table1_distance
    settings = settings or module("core").Settings()
    scene = context.scene
    scene.frame_set(1)
    info = rig.build(armature, side)
    bones, arm = info.bones, info.arm
    axes = measure.body_axes_of(armature, bones)
    reference = measure.bone_matrix(armature, bones.keyed_chest)
    start = {pb.name: pb.matrix_basis.copy() for pb in armature.pose.bones}
    # the wrist's distance from the spine axis that reads a row (table1_distance inverted)
    scale = settings.table1_arm_length_m / arm.arm_length
    wrist_distance = {row: row / scale - settings.table1_hand_point * arm.hand_length
                      for row in rows}
    out = []
    for row in rows:
        for direction in directions:
            armature.animation_data_clear()
            for pb in armature.pose.bones:
                pb.matrix_basis = start[pb.name]
            scene.frame_set(1)
            target = bpy.data.objects.new(f"Table1 {row} {direction}", None)
            target.location = axes.point(direction, wrist_distance[row],
                                         -drop * arm.arm_length, side)
            scene.collection.objects.link(target)
            request = pipeline.Request(armature=armature.name, targets=[target.name],
                                       task="reach", side=side, frame_start=1,
                                       settings=settings, draw=False)
            result = pipeline.run(context, request, bake=True).results[0]
            scene.frame_set(result.frame_end)
            at = measure.arrival(armature, bones, side, axes, reference)
            out.append({
                "row_m": row, "direction_deg": float(direction), "success": result.success,
                "arm_length": arm.arm_length, "hand_length": arm.hand_length,
                "reason": result.reason,
                "wrist_direction_deg": at["wrist_direction_deg"],
                "wrist_distance": at["wrist_distance"],
                "table1_distance_m": float(table1_distance(at["wrist_distance"], arm.arm_length,
                                                           arm.hand_length, settings)),
                "target_error": (at["wrist"] - target.location).length / arm.arm_length,
                "chest_yaw_deg": at["chest_yaw_deg"],
            })
            bpy.data.objects.remove(target)
    armature.animation_data_clear()
    for pb in armature.pose.bones:
        pb.matrix_basis = start[pb.name]
    scene.frame_set(1)
    return out


def table1_value(direction_deg, distance_m, cap):
    """Table 1 (the paper's rows, interpolated and extrapolated linearly in distance)."""
    from reach_addon.core.torso import chest_rotation_deg

    return float(chest_rotation_deg(float(direction_deg), float(distance_m), cap))


def plot(points, path, cap, title):
    """Table 1's two lines and the baked points, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from reach_addon.core.torso import TABLE1

    fig, ax = plt.subplots(figsize=(7.2, 4.4), dpi=110)
    x = np.linspace(0, 180, 361)
    colours = {0.75: "#1f77b4", 0.85: "#d62728"}
    for (row, slope, intercept) in TABLE1:
        ax.plot(x, np.clip(slope * x + intercept, 0, cap), color=colours[row], lw=1.6,
                label=f"Table 1, {row * 100:.0f} cm: {slope:.2f} × direction {intercept:+.1f}°")
        mine = [p for p in points if p["row_m"] == row and p["success"]]
        ax.scatter([p["wrist_direction_deg"] for p in mine], [p["chest_yaw_deg"] for p in mine],
                   color=colours[row], edgecolor="black", zorder=3, s=36,
                   label=f"baked, hand {row * 100:.0f} cm out (measured on the evaluated bones)")
        failed = [p for p in points if p["row_m"] == row and not p["success"]]
        if failed:
            ax.scatter([p["direction_deg"] for p in failed], [0] * len(failed), marker="x",
                       color=colours[row], label=f"not reached ({row * 100:.0f} cm)")
    ax.axhline(cap, color="grey", ls=":", lw=1)
    ax.text(2, cap + 0.8, f"cap {cap:.0f}°", color="grey", fontsize=8)
    ax.set_xlim(0, 180)
    ax.set_ylim(-2, cap + 6)
    ax.set_xlabel("reach direction (° from straight ahead toward the reaching side)")
    ax.set_ylabel("chest rotation at arrival (°)")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7.5, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(output=ROOT / "bench") -> dict:
    """The sweep on the demo character (the core's standard figure's size, no obstacles);
    writes ``table1.png`` and returns the points with Table 1's value and the error."""
    import bpy

    sys.path.insert(0, str(ROOT))
    import reach_addon
    from reach_addon import demo
    from reach_addon.core import Settings

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.import_scene.fbx(filepath=str(demo._rig_file()))
    armature = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    if armature.animation_data is not None:
        armature.animation_data.action = None
    bpy.context.view_layer.update()
    from reach_addon.blender import rig

    demo._arms_down(armature, rig.build(armature, "right"))
    settings = Settings()
    points = sweep(bpy.context, armature, reach_addon, settings=settings)
    for p in points:
        p["table1_deg"] = table1_value(p["wrist_direction_deg"], p["table1_distance_m"],
                                       settings.chest_rotation_max)
        p["error_deg"] = p["chest_yaw_deg"] - p["table1_deg"]
    output = Path(output)
    plot(points, output / "table1.png", settings.chest_rotation_max,
         "Chest rotation at arrival: Table 1 and Reach's baked reaches "
         "(Quaternius Female Casual, CC0)")
    ok = [p for p in points if p["success"]]
    return {"points": points, "reached": len(ok), "reaches": len(points),
            "max_abs_error_deg": max((abs(p["error_deg"]) for p in ok), default=None)}


if __name__ == "__main__":
    import bpy  # noqa: F401  (the wheel's mathutils)

    result = main()
    print(json.dumps({k: v for k, v in result.items() if k != "points"}, indent=2))
