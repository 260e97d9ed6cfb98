"""Plan and Bake in Blender's interface in a scene holding every object type (built by
``obstacle_types.py``), then save the file: Reach must never take Blender down.

    xvfb-run -s "-screen 0 1600x1000x24" blender SCENE.blend --python gui_obstacles.py -- \
        OUT_DIR ARMATURE TARGET

Runs as ``bpy.app.timers`` callbacks in the live event loop: Plan and Bake invoked as the
panel's buttons do (``INVOKE_DEFAULT`` in the 3D viewport) and waited for, a redraw of the
window, then ``wm.save_as_mainfile`` to OUT_DIR/saved.blend. What happened goes to
OUT_DIR/session.json; then Blender quits.
"""

import json
import sys
import time
from pathlib import Path

import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import timer_session  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
OUT, ARMATURE, TARGET = Path(ARGS[0]), ARGS[1], ARGS[2]
seen = {"blender": bpy.app.version_string, "steps": []}


def override():
    win = bpy.context.window_manager.windows[0]
    area = max((a for a in win.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == "WINDOW")
    area.spaces.active.show_region_ui = True
    return bpy.context.temp_override(window=win, area=area, region=region)


def run_modal(name):
    props = bpy.context.scene.reach
    with override():
        result = getattr(bpy.ops.reach, name)("INVOKE_DEFAULT")
    t0 = time.monotonic()
    while props.running:
        if time.monotonic() - t0 > 90:
            raise RuntimeError(f"reach.{name} still running after 90 s")
        yield 0.25
    with override():
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=2)
    seen["steps"].append({"step": name, "invoked": sorted(result), "status": props.status,
                          "result": json.loads(props.last_result or "{}")})


def session():
    props = bpy.context.scene.reach
    props.armature = bpy.data.objects[ARMATURE]
    props.target = bpy.data.objects[TARGET]
    props.arm = "RIGHT"
    props.settings.step = 0.04
    yield 0.5
    yield from run_modal("plan")
    yield from run_modal("bake")
    yield 0.5
    path = OUT / "saved.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    seen["saved"] = str(path)
    seen["alive_after_save"] = bool(bpy.context.window_manager.windows)


timer_session.drive(session(), seen, OUT, 200.0, first_interval=1.0)
