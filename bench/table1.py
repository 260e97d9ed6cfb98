"""Table 1 on baked motion: the chest rotation a figure arrives with, against the paper.

``make bench`` runs :func:`main`: :func:`verification.table1.sweep` on the demo character
(the core's standard figure's size, no obstacles), then ``bench/table1.png``: Table 1's two
lines and the baked chest rotations as points. It returns the points with Table 1's value
and the error (degrees), and how many reached.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


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
    from verification.table1 import sweep

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.import_scene.fbx(filepath=str(demo.scene_.rig_file()))
    armature = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    if armature.animation_data is not None:
        armature.animation_data.action = None
    bpy.context.view_layer.update()
    from reach_addon.blender import rig

    demo.scene_.arms_down(armature, rig.build(armature, "right"))
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
