"""How many leans a refused reach should try: the time and the outcome of Plan (no bake)
for each ``LEAN_TRIES`` (:data:`reach_addon.core.whole_body.LEAN_TRIES`).

``python bench/lean_tries.py [--tries 1,2,4,6] [--rigs ...] [--out FILE]`` plans, on each
rig of the test suite read from a file and Blender's metarig, standing on a level floor,
the scenes below, built in the rig's own body frame and sized by its arm (positions are
(forward, outward, up) arm lengths from the reaching shoulder), with *Lean* on, once for
each number of tries; prints a table and writes ``out/lean_tries.json``:

- ``far``: a cup 1.3 ahead, 0.1 below (the lean done-when);
- ``table``: a cup 1.25 ahead just over a table whose top is 0.85 below the shoulder and
  whose near edge is 0.35 ahead (the table done-when);
- ``low shelf``: a cup 1.2 ahead, 0.3 below, under a board 0.15 above it that reaches
  back to 0.5 ahead: a lean deep enough brings the head or chest against the board, so
  the leans are refused in turn;
- ``beyond``: a cup 2.0 ahead, 0.4 below: beyond every lean, so no lean is ranked and
  the reach goes to the step (the number of tries should not matter here).

Each plan is timed once (the first run of a rig is preceded by one untimed plan, so the
import's one-off costs are not in the figures). The bench changes no code; it sets the
module constant, which :func:`~reach_addon.core.whole_body._lean_toward` reads at each call.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
for p in (ROOT, ROOT / "tests" / "blender", ROOT / "tests"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

RIGS = ("cesium", "quaternius", "gomakehuman", "goblin", "alien", "knight", "malebase",
        "metarig")
SCENES = ("far", "table", "low shelf", "beyond")


def scene(name, armature, info):
    """The target empty of scene ``name`` (module docstring), and its obstacles, added to
    the current file, on the floor the step test stands the rig on
    (``test_body_step.floor``: level under gravity, its top the skin's lowest point; one
    built along the body's axes is tilted 1-7° on these rigs, and a step sinks into it)."""
    import everyday
    from test_body_squat import floor_top
    from test_body_step import floor as level_floor
    up = np.asarray(info.frame.up, float)
    length = info.arm.arm_length
    shoulder = np.asarray(info.joints_world["shoulder"], float)
    floor = (floor_top(armature, info) - float(shoulder @ up)) / length
    level_floor(armature, info)
    if name == "far":
        where = (1.3, 0.0, -0.1)
    elif name == "table":
        everyday.box(info, "Table", (0.35, -0.6, floor), (1.6, 0.6, -0.85))
        radius = max(info.arm.forearm_radius, info.arm.hand_radius) / length
        where = (1.25, 0.0, -0.85 + radius + 0.03)
    elif name == "low shelf":
        everyday.box(info, "Board", (0.5, -0.6, -0.15), (1.6, 0.6, -0.1))
        where = (1.2, 0.0, -0.3)
    else:
        where = (2.0, 0.0, -0.4)
    ob = bpy.data.objects.new("Cup", None)
    ob.location = tuple(float(x) for x in everyday.at(info, *where))
    bpy.context.scene.collection.objects.link(ob)
    return ob


def plan_once(kind, name, tries):
    import rigs

    from reach_addon.blender import pipeline
    from reach_addon.blender import rig as rig_mod
    from reach_addon.core import Settings, whole_body
    armature = rigs.load(kind)
    rigs.rest_still(armature)
    info = rig_mod.build(armature, "right")
    target = scene(name, armature, info)
    whole_body.LEAN_TRIES = tries
    request = pipeline.Request(armature.name, [target.name], task="reach", side="right",
                               frame_start=1, draw=False,
                               settings=Settings().replace(lean=True))
    t0 = time.perf_counter()
    outcome = pipeline.run(bpy.context, request, bake=False)
    seconds = time.perf_counter() - t0
    r = outcome.results[0]
    return {"rig": kind, "scene": name, "tries": tries, "seconds": round(seconds, 3),
            "success": bool(r.success), "reason": r.reason,
            "lean_deg": r.stats.get("lean_deg"), "steps": r.stats.get("step_count", 0)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tries", default="1,2,4,6")
    parser.add_argument("--rigs", default=",".join(RIGS))
    parser.add_argument("--out", default=str(ROOT / "out" / "lean_tries.json"))
    args = parser.parse_args(argv)
    tries = [int(t) for t in args.tries.split(",")]
    rows = []
    for kind in args.rigs.split(","):
        plan_once(kind, "far", tries[-1])              # untimed: one-off costs
        for name in SCENES:
            for n in tries:
                row = plan_once(kind, name, n)
                rows.append(row)
                print(f"{kind:12s} {name:10s} tries {n}: {row['seconds']:7.2f} s  "
                      f"{'reached' if row['success'] else row['reason']:14s} "
                      f"lean {row['lean_deg']}  steps {row['steps']}", flush=True)
    print("\ntotal seconds and reaches per LEAN_TRIES:")
    for n in tries:
        mine = [r for r in rows if r["tries"] == n]
        print(f"  {n}: {sum(r['seconds'] for r in mine):8.1f} s, "
              f"{sum(r['success'] for r in mine)} of {len(mine)} reached")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
