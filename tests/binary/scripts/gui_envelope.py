"""The reach envelope's overlay in Blender's interface, driven from inside Blender:

    xvfb-run -s "-screen 0 1600x1000x24" blender SCENE.blend --python gui_envelope.py -- \
        OUT_DIR ARMATURE

1. the 3D viewport looks at the character's reaching side from the front, the sidebar open;
2. ``reach.envelope`` is invoked as the Envelope panel's Compute button does (modal, with
   progress) and waited for;
3. a screenshot with the overlay shown (``envelope_on.png``), one with it hidden
   (``envelope_off.png``), and the window positions of the drawn points of each class
   (projected with the view's own matrices), for the test to find them in the pictures.

What it saw goes to ``OUT_DIR/session.json``; then Blender quits.
"""

import sys
import time
from pathlib import Path

import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import timer_session  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
OUT, ARMATURE = Path(ARGS[0]), ARGS[1]
seen = {"blender": bpy.app.version_string, "steps": []}


def note(step, **info):
    seen["steps"].append({"step": step, **info})


def ui():
    win = bpy.context.window_manager.windows[0]
    area = max((a for a in win.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    return win, area, {r.type: r for r in area.regions}


def screenshot(name):
    win, area, regions = ui()
    with bpy.context.temp_override(window=win, area=area, region=regions["WINDOW"]):
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=2)
        bpy.ops.screen.screenshot(filepath=str(OUT / f"{name}.png"))


def session():
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    from mathutils import Vector

    mod = sys.modules["reach_addon"]
    scene = bpy.context.scene
    props = scene.reach
    props.armature = bpy.data.objects[ARMATURE]
    props.arm = "RIGHT"
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    win, area, regions = ui()
    area.spaces.active.show_region_ui = True
    info = mod.blender.rig.build(props.armature, "right")
    r3d = area.spaces.active.region_3d
    r3d.view_perspective = "PERSP"
    r3d.view_location = Vector(info.joints_world["shoulder"].tolist())
    eye = (1.0 * Vector(info.frame.forward.tolist()) + 0.4 * Vector(info.frame.up.tolist())
           + 0.7 * Vector(info.frame.right.tolist())).normalized()
    r3d.view_rotation = (-eye).to_track_quat("-Z", "Y")
    r3d.view_distance = 4.5 * info.arm.arm_length
    yield 1.0

    t0 = time.monotonic()
    with bpy.context.temp_override(window=win, area=area, region=regions["WINDOW"]):
        result = bpy.ops.reach.envelope("INVOKE_DEFAULT")
    progress = []
    while props.running:
        if time.monotonic() - t0 > 120:
            raise RuntimeError("reach.envelope still running after 120 s")
        progress.append(round(props.progress, 3))
        yield 0.2
    outcome = mod.blender.envelope.last(scene)
    note("computed", result=sorted(result), seconds=round(time.monotonic() - t0, 2),
         progress=progress, counts=outcome.envelope.counts())
    yield 0.5
    screenshot("envelope_on")
    points, classes = mod.blender.envelope.drawn(outcome)
    window = regions["WINDOW"]
    where = {}
    for p, c in zip(points, classes):
        xy = location_3d_to_region_2d(window, r3d, Vector(p.tolist()))
        if xy is not None:
            # window pixels, origin top left (as the screenshot's rows)
            where.setdefault(int(c), []).append([window.x + xy.x, win.height - (window.y + xy.y)])
    note("projected", where=where, window=[window.x, window.y, window.width, window.height],
         size=[win.width, win.height])
    scene.reach_envelope.show = False
    yield 0.5
    screenshot("envelope_off")
    note("hidden")


OUT.mkdir(parents=True, exist_ok=True)
timer_session.drive(session(), seen, OUT, 200.0, first_interval=1.0)
