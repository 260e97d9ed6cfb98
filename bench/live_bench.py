"""Live-mode update times: how long one live update takes while the target moves.

``python -m bench.live_bench [n]`` prints the numbers; :func:`chase_update_times` is what
the full benchmark calls (it reports ``chase_update_ms_p50`` / ``chase_update_ms_p95``;
the aim is a p95 of at most 16 ms, one frame at 60 Hz).

What is measured
----------------
The Quaternius figure (``tests/data/rigs``, CC0) stands behind a table; its right hand
chases a target round a loop in front of the shoulder, the way an animated target is
scrubbed or a user drags one with G: before each update the target moves on by one frame
of a 24 fps motion (0.026 arm lengths, the loop takes 36 frames). One sample is the wall
time of one call of :func:`reach_addon.blender.live.update` — the entry point Blender's
timer calls — with its default budget (1/30 s): reading the target and the obstacles'
signature, the core's re-plan from the pose on screen, and writing the new pose to the
bones. The depsgraph evaluation of the posed, skinned character that Blender runs before
the next redraw is included too (``view_layer.update()`` at the start of the next update is
inside the timed call), so the numbers are what the user waits for. The first reach from
the rest pose is planned before timing starts (that is a reach, not a live update).

``core_p50_ms`` / ``core_p95_ms`` time the core's :meth:`LiveSession.advance` alone on the
same motion, without Blender; ``busy_updates`` counts updates that ran out of budget and
continued on the next one.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RIG = ROOT / "tests" / "data" / "rigs" / "Quaternius_Female_Casual.fbx"
FRAMES_PER_LOOP = 36


def _scene():
    """The figure, a table and a target; returns (armature, target, loop points)."""
    import bpy
    from mathutils import Matrix

    from reach_addon.blender import rig

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.import_scene.fbx(filepath=str(RIG))
    arm = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    if arm.animation_data is not None:
        arm.animation_data.action = None
    for pb in arm.pose.bones:
        pb.matrix_basis = Matrix.Identity(4)
    bpy.context.view_layer.update()
    info = rig.build(arm, "right")
    f, length = info.frame, info.arm.arm_length
    centre = (info.joints_world["shoulder"] + 0.6 * length * f.forward + 0.1 * length * f.right
              - 0.05 * length * f.up)
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    table = bpy.context.object
    table.name = "Table"
    m = np.eye(4)
    m[:3, :3] = np.column_stack([f.right, f.forward, f.up]) * np.array([0.9, 0.9, 0.04]) * length
    m[:3, 3] = centre - 0.3 * length * f.up
    table.matrix_world = Matrix(m.tolist())
    target = bpy.data.objects.new("Ball", None)
    bpy.context.scene.collection.objects.link(target)
    a = 2 * np.pi * np.arange(FRAMES_PER_LOOP) / FRAMES_PER_LOOP
    loop = centre + 0.15 * length * (np.cos(a)[:, None] * f.right + np.sin(a)[:, None] * f.up)
    target.location = loop[0]
    bpy.context.view_layer.update()
    return arm, target, loop


def chase_update_times(n: int = 200) -> dict:
    """Times of ``n`` live updates as the target moves one frame per update (see the
    module docstring). Returns p50_ms, p95_ms, samples (ms, in order) and a few more."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    import bpy

    from reach_addon.blender import live, pipeline
    from reach_addon.core.live import LiveSession

    arm, target, loop = _scene()
    request = pipeline.Request(armature=arm.name, targets=[target.name], side="right")
    state = live.start(bpy.context, request)
    try:
        while live.update(bpy.context).busy:        # the first reach, untimed
            pass
        samples, busy = [], 0
        for k in range(1, n + 1):
            target.location = loop[k % len(loop)]
            t0 = time.perf_counter()
            report = live.update(bpy.context)
            samples.append((time.perf_counter() - t0) * 1000.0)
            busy += report.busy
        session = state.session
        info = state.info
    finally:
        live.stop(push_undo=False)

    # the core alone, same motion, same start
    core = LiveSession(info.arm, state.cache.obstacles, session.settings, info.start, "Ball")
    core.set_target(loop[0])
    core.run()
    core_samples = []
    for k in range(1, n + 1):
        core.set_target(loop[k % len(loop)])
        t0 = time.perf_counter()
        while core.busy:
            core.advance()
        core_samples.append((time.perf_counter() - t0) * 1000.0)
    s, c = np.array(samples), np.array(core_samples)
    return {
        "p50_ms": float(np.percentile(s, 50)), "p95_ms": float(np.percentile(s, 95)),
        "samples": [round(v, 3) for v in samples],
        "max_ms": float(s.max()), "busy_updates": int(busy),
        "core_p50_ms": float(np.percentile(c, 50)), "core_p95_ms": float(np.percentile(c, 95)),
        "obstacle_builds": int(state.cache.builds),
    }


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    n = int(argv[0]) if argv else 200
    r = chase_update_times(n)
    print(f"live update while chasing, {n} updates (Quaternius figure, table, 24 fps loop)")
    print(f"  chase_update_ms_p50 {r['p50_ms']:7.2f}")
    print(f"  chase_update_ms_p95 {r['p95_ms']:7.2f}   (aim: <= 16)")
    print(f"  max                 {r['max_ms']:7.2f}")
    print(f"  core only p50/p95   {r['core_p50_ms']:7.2f} / {r['core_p95_ms']:.2f}")
    print(f"  updates over budget {r['busy_updates']}, obstacle BVH builds {r['obstacle_builds']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
