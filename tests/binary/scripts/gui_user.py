"""A new user's session with Reach in Blender's interface, on a small character (0.2 m tall,
armature scale 0.0012, as a Mixamo import is), driven from inside Blender:

    xvfb-run -s "-screen 0 1600x1000x24" blender SCENE.blend --python gui_user.py -- \
        OUT_DIR ARMATURE TARGET

What a user met there, each done as the user does it where the interface is the point
(clicks on the panel's own buttons, G and Ctrl+Z on the X display with ``xdotool``):

1. the scene gets what the user's had: a camera, a light, a box "Table" round the resting
   left hand with a target "Inside" in it, a target "Near" just beyond the right arm's
   reach and a target "Far" 5 m ahead, a little below the shoulder;
2. the Target field's list (clicked open, screenshot), then each object typed into it and
   Enter pressed: which of them the field takes;
3. Arm = Right, Plan for "Far" with the character leaning 3° (its body's up axis off the
   vertical): the reason;
4. Live on (its button) for "Near" and for "Far": the Live panel's status as the sidebar
   drew it, beside what ``live.status_lines`` gives;
5. Live on for the plate's target, the target moved twice with G (each move an undo step),
   Live off (its button), one Ctrl+Z: the pose and the target before, during and after;
6. Arm = Auto, Plan for "Inside": the Result panel as drawn;
7. the armature keyed to slide while the arm would reach, Bake clicked: the popup Blender
   shows (its region and text, read from the screen's temporary regions), the Result
   panel as drawn and the Info log's reports (``ui.reports_to_textblock``).

Everything seen goes to ``OUT_DIR/session.json`` with the screenshots; then Blender quits.
"""

import json
import math
import sys
import time
from pathlib import Path

import bpy
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1] / "blender"))    # tests/blender/rigs.py
import drawn_text  # noqa: E402
import rigs  # noqa: E402
import timer_session  # noqa: E402
from gui_window import button_xy, override, reach_tab, to_screen, ui, xdotool  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
OUT, ARMATURE, TARGET = Path(ARGS[0]), ARGS[1], ARGS[2]
DEADLINE_S = 420.0
#: ``Panel.flag`` bit of a collapsed panel (see ``gui_session.py``).
PNL_CLOSED = 1 << 2
seen = {"blender": bpy.app.version_string, "steps": [], "draws": {}}
t_start = time.monotonic()


def note(step, **info):
    seen["steps"].append({"step": step, "t": round(time.monotonic() - t_start, 2), **info})


def _hook(name):
    def hook(self, context):
        seen["draws"][name] = seen["draws"].get(name, 0) + 1
    return hook


for _name in ("REACH_PT_main", "REACH_PT_result", "REACH_PT_live"):
    getattr(bpy.types, _name).append(_hook(_name))


def draws(name):
    return seen["draws"].get(name, 0)


def reach():
    return sys.modules["reach_addon"]


def redraw(times=2):
    win, area, regions = ui()
    with bpy.context.temp_override(window=win, area=area, region=regions["UI"]):
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=times)


def screenshot(name):
    win, area, regions = ui()
    with bpy.context.temp_override(window=win, area=area, region=regions["WINDOW"]):
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
        bpy.ops.screen.screenshot(filepath=str(OUT / f"{name}.png"))
    note("screenshot", name=name, window=[win.width, win.height])


def open_only(names):
    """The Reach panels ``names`` open, every other one collapsed (DNA flags, as
    ``gui_session.show_only``), repeated until the sidebar has settled."""
    reach_panels = {getattr(c, "bl_idname", c.__name__) for c in bpy.types.Panel.__subclasses__()
                    if getattr(c, "bl_category", "") == "Reach" and c.is_registered}
    for _ in range(len(reach_panels) + 2):
        changed = False
        for panel in drawn_text.panels(ui()[2]["UI"]):
            if panel["name"] in reach_panels:
                flag = panel["flag"] & ~PNL_CLOSED if panel["name"] in names else \
                    panel["flag"] | PNL_CLOSED
                if flag != panel["flag"]:
                    drawn_text.set_panel_flag(panel["address"], flag)
                    changed = True
        redraw(1)
        if not changed:
            return


def panel(name):
    """[(given, drawn)] of panel ``name`` as the sidebar last drew it (None if not drawn)."""
    return drawn_text.panel_text(ui()[2]["UI"], name)


def button(panel_name, given):
    """Screen coordinates of the middle of the button of panel ``panel_name`` whose text is
    ``given`` (as the sidebar last drew it; a field showing a name has none of its own,
    and is found by the name it shows)."""
    sidebar = ui()[2]["UI"]
    box = next(p for p in drawn_text.panels(sidebar) if p["name"] == panel_name)
    for b in drawn_text.panel_buttons(sidebar, panel_name) or ():
        if b["given"] == given or (not b["given"] and b["drawn"] == given):
            x0, x1, y0, y1 = b["rect"]
            rect = [x0 + box["ofsx"], x1 + box["ofsx"], y0 + box["ofsy"], y1 + box["ofsy"]]
            return button_xy(sidebar, rect, drawn_text.view2d_cur(sidebar))
    raise RuntimeError(f"no button {given!r} drawn in {panel_name}: "
                       f"{drawn_text.panel_text(sidebar, panel_name)}")


def click(panel_name, given):
    """Click the button (a generator: the sidebar slides panels into place over several
    redraws after one opens or closes, so the button is clicked where it has come to
    rest)."""
    last = None
    for _ in range(20):
        redraw(1)
        xy = button(panel_name, given)
        if xy == last:
            break
        last = xy
        yield 0.15
    xdotool("mousemove", *xy)
    yield 0.4                    # the button under the pointer becomes active first
    xdotool("click", 1)


def to_view(fx=0.35, fy=0.45):
    xdotool("mousemove", *to_screen(ui()[2]["WINDOW"], fx, fy))


def wait_running(what, timeout_s=120):
    props = bpy.context.scene.reach
    t0 = time.monotonic()
    while props.running:
        if time.monotonic() - t0 > timeout_s:
            raise RuntimeError(f"{what} still running after {timeout_s} s")
        yield 0.05


def wait_live(timeout_s=30):
    """Until the live session rests (it has updated, and its re-plan is done, at three looks
    in a row), or ``timeout_s``."""
    live = reach().blender.live
    t0 = time.monotonic()
    resting = 0
    while resting < 3 and time.monotonic() - t0 < timeout_s:
        yield 0.1
        st = live.state()
        if st is None and time.monotonic() - t0 > 3.0:
            break                                   # Live is not on
        resting = resting + 1 if st is not None and st.timings and not st.session.busy else 0
    yield 0.3


def pose():
    arm = bpy.data.objects[ARMATURE]
    return {pb.name: [round(x, 5) for row in pb.matrix_basis for x in row] for pb in arm.pose.bones}


def location(name):
    return [round(x, 7) for x in bpy.data.objects[name].location]


def frame_the_character():
    from mathutils import Vector

    _win, area, _regions = ui()
    arm = bpy.data.objects[ARMATURE]
    info = reach().blender.rig.build(arm, "right")
    r3d = area.spaces.active.region_3d
    r3d.view_perspective = "PERSP"
    up, forward = Vector(info.frame.up.tolist()), Vector(info.frame.forward.tolist())
    shoulder = Vector(info.joints_world["shoulder"].tolist())
    r3d.view_location = shoulder - 1.2 * info.arm.arm_length * up
    r3d.view_rotation = (-(forward + 0.3 * up).normalized()).to_track_quat("-Z", "Y")
    r3d.view_distance = 6.0 * info.arm.arm_length
    area.spaces.active.clip_start = 0.001


def add_extras():
    """What the user's scene had besides the character: a camera, a light, the table round
    the left hand with a target in it, a target just beyond reach and one 5 m away."""
    scene = bpy.context.scene
    arm = bpy.data.objects[ARMATURE]
    for name, data in (("Camera", bpy.data.cameras.new("Camera")),
                       ("Light", bpy.data.lights.new("Light", "POINT"))):
        ob = bpy.data.objects.new(name, data)
        ob.location = (0.5, -0.5, 0.4)
        scene.collection.objects.link(ob)
    mod = reach()
    right, left = (mod.blender.rig.build(arm, s) for s in ("right", "left"))
    table, inside = rigs.table_at_the_hand(left)
    f, length = right.frame, right.arm.arm_length
    shoulder = right.joints_world["shoulder"]
    near = rigs.add_target("Near", shoulder + 1.25 * length * f.forward)
    level = np.array([f.forward[0], f.forward[1], 0.0]) / np.hypot(f.forward[0], f.forward[1])
    far = rigs.add_target("Far", shoulder + 5.0 * level - np.array([0.0, 0.0, 0.01]))
    for ob in (inside, near, far, bpy.data.objects[TARGET]):
        ob.empty_display_size = 0.08 * length
    bpy.context.view_layer.update()
    return {"table": table.name, "inside": inside.name, "near": near.name, "far": far.name,
            "arm_length": length, "shoulder_z": float(shoulder[2]), "far_z": float(far.location.z)}


def target_list(extras):
    """The Target field opened with a click (screenshot of its list), then each object's
    name typed into it and Enter pressed: the target the field then holds."""
    props = bpy.context.scene.reach
    cup = bpy.data.objects[TARGET]
    typed, opened = {}, {}
    names = ["Camera", "Light", ARMATURE, "Reach Targets", "Reach Trajectory", extras["inside"]]
    for k, name in enumerate(names):
        props.target = cup
        yield 0.3
        redraw()
        yield from click("REACH_PT_main", cup.name)
        yield 0.8
        opened[name] = bool(drawn_text.popups(ui()[0].screen))
        if k == 0:
            screenshot("target_list")
        xdotool("type", "--delay", "20", name)
        yield 0.6
        xdotool("key", "Return")
        yield 0.6
        xdotool("key", "Escape")          # closes anything left open (nothing, normally)
        yield 0.3
        typed[name] = props.target.name if props.target else None
    props.target = cup
    note("target list", typed=typed, opened=opened, objects={ob.name: ob.type for ob in bpy.data.objects})


def far_reason(extras):
    """Plan for "Far", 5 m ahead and 1 cm below the shoulder: how far above or below the
    shoulder it is along the body's own up axis (read from the bones, which lean), and the
    reason the plan gives."""
    props = bpy.context.scene.reach
    arm = bpy.data.objects[ARMATURE]
    far = bpy.data.objects[extras["far"]]
    info = reach().blender.rig.build(arm, "right")
    c = info.arm.to_canonical_points(np.array(far.matrix_world.translation))
    along = float(c[2] - info.arm.to_canonical_points(info.joints_world["shoulder"])[2])
    tilt = math.degrees(math.acos(min(1.0, abs(float(info.frame.up[2])))))
    props.target, props.arm = far, "RIGHT"
    yield 0.5
    with override():
        bpy.ops.reach.plan("INVOKE_DEFAULT")
    yield from wait_running("Plan (far)")
    yield 1.0
    redraw()
    task = json.loads(props.last_result)["tasks"][0]
    note("far", body_tilt_deg=tilt, along_body_up=along / info.arm.arm_length,
         below_in_world=extras["shoulder_z"] - extras["far_z"], reason=task["reason"],
         message=task["message"], result_text=panel("REACH_PT_result"))
    screenshot("far")


def live_status(name):
    """Live on (its button) for target ``name``; once it rests, the Live panel as drawn and
    the status lines it was drawn from; Live off."""
    props = bpy.context.scene.reach
    live = reach().blender.live
    props.target, props.arm = bpy.data.objects[name], "RIGHT"
    yield 0.3
    redraw()
    yield from click("REACH_PT_live", "Live")
    yield from wait_live(90)
    redraw(3)
    active = live.is_active()
    note(f"live status {name}", active=active, computed=live.status_lines(),
         drawn=panel("REACH_PT_live"),
         reason=live.state().session.status.reason if active else None)
    screenshot(f"live_{name.lower()}")
    if active:
        yield from click("REACH_PT_live", "Live")
    yield 0.5


def live_undo():
    """Live on for the plate's target (its button), the target moved twice with G in the
    viewport, Live off (its button), Ctrl+Z once."""
    props = bpy.context.scene.reach
    live = reach().blender.live
    cup = bpy.data.objects[TARGET]
    props.target, props.arm = cup, "RIGHT"
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    cup.select_set(True)
    bpy.context.view_layer.objects.active = cup
    with override():
        bpy.ops.ed.undo_push(message="Reach test: before Live")
    yield 0.5
    before = {"pose": pose(), "target": location(TARGET)}
    redraw()
    yield from click("REACH_PT_live", "Live")
    yield from wait_live()
    on = {"active": live.is_active(), "pose": pose()}
    moves = []
    for dx in (60, 50):
        to_view(0.45, 0.5)
        yield 0.3
        xdotool("key", "g")
        yield 0.4
        xdotool("mousemove_relative", "--", dx, -dx // 2)
        yield 0.4
        xdotool("click", "1")
        yield 0.15                          # the search under way
        moves.append(location(TARGET))
    yield from wait_live()
    shown = {"pose": pose(), "target": location(TARGET), "active": live.is_active(),
             "status": live.status_lines()}
    redraw()
    yield from click("REACH_PT_live", "Live")
    yield 0.8
    off = {"pose": pose(), "target": location(TARGET), "active": live.is_active()}
    to_view(0.45, 0.5)
    yield 0.3
    xdotool("key", "ctrl+z")
    yield 1.5
    undone = {"pose": pose(), "target": location(TARGET)}
    screenshot("live_undone")
    note("live undo", before=before, on=on, moves=moves, shown=shown, off=off, undone=undone)


def auto_result(extras):
    props = bpy.context.scene.reach
    props.target, props.arm = bpy.data.objects[extras["inside"]], "AUTO"
    yield 0.5
    with override():
        bpy.ops.reach.plan("INVOKE_DEFAULT")
    yield from wait_running("Plan (auto)")
    yield 1.0
    redraw(3)
    from reach_addon.ui.operators import result_lines

    note("auto", result=json.loads(props.last_result), computed=result_lines(props),
         drawn=panel("REACH_PT_result"))
    screenshot("auto")


def reports(out):
    """The Info log's reports, as a user copies them (a generator): the timeline turned
    into an Info editor, every report selected and copied (``info.report_copy``), read from
    the clipboard into ``out["text"]``; the timeline turned back."""
    win = ui()[0]
    area = next(a for a in win.screen.areas if a.ui_type == "TIMELINE")
    area.ui_type = "INFO"
    yield 0.5
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=win, area=area, region=region):
        bpy.ops.info.select_all(action="SELECT")
        bpy.ops.info.report_copy()
    out["text"] = bpy.context.window_manager.clipboard
    screenshot("info_log")
    area.ui_type = "TIMELINE"
    yield 0.3


def bake_refusal():
    """The arm put back in its rest pose and the armature keyed to slide half an arm length
    while the arm would reach; Bake clicked: the popup, the Result panel, the Info log."""
    props = bpy.context.scene.reach
    arm = bpy.data.objects[ARMATURE]
    props.target, props.arm = bpy.data.objects[TARGET], "RIGHT"
    from mathutils import Matrix

    for pb in arm.pose.bones:             # the rest pose: a reach of some length to bake
        pb.matrix_basis = Matrix.Identity(4)
    bpy.context.view_layer.update()
    length = reach().blender.rig.build(arm, "right").arm.arm_length
    start = arm.location.copy()
    arm.keyframe_insert("location", frame=1)
    arm.location.x = start.x + 0.5 * length
    arm.keyframe_insert("location", frame=30)
    arm.location = start
    bpy.context.scene.frame_set(1)
    yield 0.5
    redraw()
    before = props.last_result
    yield from click("REACH_PT_main", "Bake")
    t0 = time.monotonic()
    yield 0.3
    yield from wait_running("Bake (refused)")
    popup = []
    while time.monotonic() - t0 < 20:
        popup = [p for p in drawn_text.popups(ui()[0].screen) if p["buttons"]]
        if popup:
            break
        yield 0.1
    yield 0.5
    popup = [p for p in drawn_text.popups(ui()[0].screen) if p["buttons"]]
    screenshot("refusal_popup")
    to_view(0.2, 0.2)                         # away from the popup: it closes
    yield 1.0
    redraw(3)
    from reach_addon.ui.operators import result_lines

    drawn = panel("REACH_PT_result")
    screenshot("refusal_result")
    log = {}
    yield from reports(log)
    note("refusal", popups=popup, result_changed=props.last_result != before,
         result=json.loads(props.last_result or "{}"), computed=result_lines(props),
         drawn=drawn, info_log=log.get("text", ""), keys=len(arm.animation_data.action.fcurves))


def session():
    props = bpy.context.scene.reach
    extras = add_extras()
    props.armature = bpy.data.objects[ARMATURE]
    props.target = bpy.data.objects[TARGET]
    props.arm = "RIGHT"
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    _win, area, regions = ui()
    frame_the_character()
    area.spaces.active.show_region_ui = True
    note("start", extras=extras, window=[ui()[0].width, ui()[0].height])
    yield 1.0
    turns = yield from reach_tab(lambda: draws("REACH_PT_main"))
    note("reach tab", turns=turns)
    to_view()
    yield 0.5
    with override():                       # a Plan first: Reach's own objects exist
        bpy.ops.reach.plan("INVOKE_DEFAULT")
    yield from wait_running("Plan")
    open_only({"REACH_PT_main", "REACH_PT_result", "REACH_PT_live"})
    yield 1.0
    screenshot("planned")

    yield from target_list(extras)
    yield from far_reason(extras)
    open_only({"REACH_PT_main", "REACH_PT_live"})
    for name in (extras["near"], extras["far"]):
        yield from live_status(name)
    yield from live_undo()
    open_only({"REACH_PT_main", "REACH_PT_result", "REACH_PT_live"})
    yield from auto_result(extras)
    yield from bake_refusal()


timer_session.drive(session(), seen, OUT, DEADLINE_S)
