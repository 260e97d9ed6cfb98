"""A user's session with Reach in Blender's interface, driven from inside Blender.

    xvfb-run -s "-screen 0 1600x1000x24" blender SCENE.blend --python gui_session.py -- \
        OUT_DIR ARMATURE TARGET [STEP]

Runs as a chain of ``bpy.app.timers`` callbacks once the window is up, so every step happens
in the live event loop with its redraws:

1. open the 3D viewport's sidebar, frame the reaching arm, and turn to the "Reach" tab the
   way a user can: the mouse wheel over the sidebar's tab strip (``xdotool``), one tab at a
   time, until Reach's main panel is drawn in the sidebar (seen by a draw hook appended to
   the panel, so the tab is found by what Blender draws, not by guessing its position);
2. Esc: start a long Bake (a fine step, searched straight at the plate) with
   ``INVOKE_DEFAULT``, check it is running, press Esc with ``xdotool``, and record
   everything a bake could have touched before and after;
3. Plan, then Bake (searched straight at the plate, so that they run long enough to watch
   their progress), each invoked as the panel's buttons do and waited for; the trajectory's
   points projected into the view are recorded, to find it in the screenshot;
4. screenshots (``screen.screenshot``) at each stage, one at the reach's end frame and
   one mid-reach seen from further away (``readme.png``, the README's picture); with each,
   the Result panel's labels as the sidebar drew them, read from the region's own buttons
   (``drawn_text``), beside the lines the operator's ``result_lines`` gives for the same
   result: the test compares the two;
5. every Reach panel in turn opened (alone with its ancestors), scrolled into view and its
   buttons read as drawn, to find any label the default sidebar width clips.

Everything seen goes to ``OUT_DIR/session.json`` (the test reads it and the screenshots);
then Blender quits. Any error is recorded there too, and ends the session.
"""

import json
import sys
import time
from pathlib import Path

import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import drawn_text  # noqa: E402
import timer_session  # noqa: E402
from gui_window import override, reach_tab, to_screen, ui, xdotool  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
OUT, ARMATURE, TARGET = Path(ARGS[0]), ARGS[1], ARGS[2]
STEP = float(ARGS[3]) if len(ARGS) > 3 else None      # the planner step for Plan and Bake
DEADLINE_S = 240.0                            # the session gives up after this long
seen = {"blender": bpy.app.version_string, "steps": [], "draws": {}}
t_start = time.monotonic()


def note(step, **info):
    seen["steps"].append({"step": step, "t": round(time.monotonic() - t_start, 2), **info})


# --- what the sidebar draws -------------------------------------------------------------------

#: (seconds into the session, progress, status) each time the main panel was drawn while
#: Plan or Bake ran: the progress the user was shown.
drawn_progress = []


def _hook(panel_name):
    def hook(self, context):
        d = seen["draws"].setdefault(panel_name, {"count": 0})
        d["count"] += 1
        d["where"] = [context.area.type, context.region.type]
        props = context.scene.reach
        if panel_name == "REACH_PT_main" and props.running:
            drawn_progress.append((time.monotonic() - t_start, props.progress, props.status))
    return hook


def _viewport_drawn():
    d = seen["draws"].setdefault("viewport", {"count": 0})
    d["count"] += 1


for _name in ("REACH_PT_main", "REACH_PT_result"):
    getattr(bpy.types, _name).append(_hook(_name))
bpy.types.SpaceView3D.draw_handler_add(_viewport_drawn, (), "WINDOW", "POST_PIXEL")


def draws(name):
    return seen["draws"].get(name, {}).get("count", 0)


# --- the window -------------------------------------------------------------------------------

def geometry():
    """Window size and the viewport's regions in window pixels, origin bottom left."""
    win, area, regions = ui()
    return {"window": [win.width, win.height],
            "area": [area.x, area.y, area.width, area.height],
            "regions": {t: [r.x, r.y, r.width, r.height] for t, r in regions.items()}}


def result_text():
    """The Result panel as the sidebar last drew it — [text given, text drawn] of each of its
    labels, read from the region (``drawn_text``), or None if it drew none — and the lines
    the operator's ``result_lines`` makes of the scene's result (None without one)."""
    from reach_addon.ui.operators import result_lines

    props = bpy.context.scene.reach
    drawn = drawn_text.panel_text(ui()[2]["UI"], "REACH_PT_result")
    return {"drawn": None if drawn is None else [list(b) for b in drawn],
            "computed": result_lines(props) if props.last_result else None}


def screenshot(name, redraws=1):
    """The whole window as a PNG, after drawing it (panels that just appeared slide into
    place over more than one redraw) so the picture is what the user now sees; and the
    Result panel's text as drawn (:func:`result_text`)."""
    win, area, regions = ui()
    with bpy.context.temp_override(window=win, area=area, region=regions["WINDOW"]):
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=redraws)
        bpy.ops.screen.screenshot(filepath=str(OUT / f"{name}.png"))
    note("screenshot", name=name, geometry=geometry(),
         panels=json.loads(json.dumps(seen["draws"])),     # what had been drawn by then
         result_text=result_text())


# --- every label of every Reach panel -------------------------------------------------------

#: ``Panel.flag`` bit of a collapsed panel (``DNA_screen_types.h``; checked: the Reach tab's
#: DEFAULT_CLOSED sub-panels have it, the main panel not).
PNL_CLOSED = 1 << 2


def reach_panels():
    """{idname: parent idname or ""} of the panels registered for the sidebar's Reach tab."""
    return {getattr(c, "bl_idname", c.__name__): getattr(c, "bl_parent_id", "")
            for c in bpy.types.Panel.__subclasses__()
            if getattr(c, "bl_category", "") == "Reach" and c.is_registered}


def redraw():
    win, area, regions = ui()
    with bpy.context.temp_override(window=win, area=area, region=regions["UI"]):
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)


def show_only(name, parents):
    """Open panel ``name`` and its ancestors, collapse every other Reach panel (its
    sub-panels too): Blender creates a sub-panel once its parent is drawn open, so this is
    repeated until nothing changes. DNA ``Panel.flag`` is written (``drawn_text``): Blender
    3.4 has no Python API to open a panel."""
    keep, p = set(), name
    while p:
        keep.add(p)
        p = parents[p]
    for _ in range(len(parents) + 2):
        changed = False
        for panel in drawn_text.panels(ui()[2]["UI"]):
            if panel["name"] in parents:
                flag = panel["flag"] & ~PNL_CLOSED if panel["name"] in keep else \
                    panel["flag"] | PNL_CLOSED
                if flag != panel["flag"]:
                    drawn_text.set_panel_flag(panel["address"], flag)
                    changed = True
        redraw()
        if not changed:
            return
    raise RuntimeError(f"{name}: the sidebar's panels did not settle")


def in_view(name):
    """The panel's box (below its header) and whether the sidebar shows all of it."""
    sidebar = ui()[2]["UI"]
    panel = next((p for p in drawn_text.panels(sidebar) if p["name"] == name), None)
    if panel is None:
        return None, False
    box = [panel["ofsy"], panel["ofsy"] + panel["sizey"]]
    cur = drawn_text.view2d_cur(sidebar)
    return box, not panel["flag"] & PNL_CLOSED and cur[2] <= box[0] and box[1] <= cur[3]


def every_label():
    """Each Reach panel in turn, alone with its ancestors open, scrolled into view with the
    mouse wheel, drawn, and its buttons read as drawn (``drawn_text.panel_buttons``): the
    text each was given, the text drawn ("…" where Blender clipped it), its type. The
    inputs are set so that the panels show their optional rows too (start frame, duration,
    obstacle collection, several targets)."""
    props = bpy.context.scene.reach
    props.use_current_frame = False
    props.auto_duration = False
    props.obstacles = "COLLECTION"
    props.task = "SEQUENCE"
    parents = reach_panels()
    sidebar = ui()[2]["UI"]
    seen_panels = {}
    for name in sorted(parents, key=lambda n: (n.count("_"), n)):
        show_only(name, parents)
        box, shown = in_view(name)
        for _ in range(80):
            if box is None or shown:
                break
            cur = drawn_text.view2d_cur(sidebar)
            xdotool("mousemove", *to_screen(sidebar, 0.5, 0.5), "click", 4 if box[1] > cur[3] else 5)
            yield 0.1
            redraw()
            box, shown = in_view(name)
        redraw()
        box, shown = in_view(name)
        seen_panels[name] = {"parent": parents[name], "box": box, "in_view": shown,
                             "cur": drawn_text.view2d_cur(sidebar),
                             "buttons": drawn_text.panel_buttons(sidebar, name)}
        screenshot(f"labels_{name}")
    note("labels", panels=seen_panels, width=sidebar.width,
         ui_scale=bpy.context.preferences.system.ui_scale)


# --- the scene --------------------------------------------------------------------------------

def keys_of(ob):
    ad = ob.animation_data
    action = ad.action if ad else None
    if action is None:
        return None, {}
    if hasattr(action, "layers"):
        curves = [fc for ly in action.layers for st in ly.strips for bag in st.channelbags
                  for fc in bag.fcurves]
    else:
        curves = list(action.fcurves)
    return action.name, {f"{fc.data_path}[{fc.array_index}]": [list(k.co) for k in fc.keyframe_points]
                         for fc in curves}


def state():
    """Everything a plan or bake could change, as plain data."""
    arm = bpy.data.objects[ARMATURE]
    action, keys = keys_of(arm)
    return {
        "objects": {ob.name: [round(x, 6) for row in ob.matrix_world for x in row]
                    for ob in bpy.data.objects},
        "collections": sorted(c.name for c in bpy.data.collections),
        "actions": sorted(a.name for a in bpy.data.actions),
        "curves": sorted(c.name for c in bpy.data.curves),
        "materials": sorted(m.name for m in bpy.data.materials),
        "armature_action": action, "keys": keys,
        "pose": {pb.name: [round(x, 6) for row in pb.matrix_basis for x in row]
                 for pb in arm.pose.bones},
        "frame": bpy.context.scene.frame_current,
        "last_result": bpy.context.scene.reach.last_result,
    }


def trajectory_on_screen():
    """The trajectory curve's points projected into the viewport (region pixels)."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d

    ob = bpy.data.objects.get("Reach Trajectory")
    if ob is None:
        return []
    _win, area, regions = ui()
    r3d = area.spaces.active.region_3d
    out = []
    for p in ob.data.splines[0].points:
        xy = location_3d_to_region_2d(regions["WINDOW"], r3d, ob.matrix_world @ p.co.xyz)
        if xy is not None:
            out.append([xy.x, xy.y])
    return out


def scale_on_screen():
    """How big the trajectory's tube and the arm are drawn where the path is: the pixels
    across the tube's diameter (its bevel) and across an arm's length, both measured at
    the middle of the path, parallel to the screen; with the bevel and the arm length."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    from mathutils import Vector

    ob = bpy.data.objects.get("Reach Trajectory")
    _win, area, regions = ui()
    r3d = area.spaces.active.region_3d
    points = ob.data.splines[0].points
    middle = ob.matrix_world @ points[len(points) // 2].co.xyz
    across = r3d.view_rotation @ Vector((1.0, 0.0, 0.0))
    length = sys.modules["reach_addon"].blender.rig.build(bpy.data.objects[ARMATURE],
                                                          "right").arm.arm_length

    def pixels(size):
        a = location_3d_to_region_2d(regions["WINDOW"], r3d, middle)
        b = location_3d_to_region_2d(regions["WINDOW"], r3d, middle + size * across)
        return (b - a).length

    bevel = ob.data.bevel_depth
    return {"bevel": bevel, "arm_length": length, "tube_px": pixels(2 * bevel),
            "arm_px": pixels(length)}


def frame_the_arm(distance=2.2, height=0.5):
    """Look at the reach from the front, close enough that the arm fills the viewport (or
    from ``distance`` arm lengths, ``height`` the share of the eye's direction upward)."""
    from mathutils import Vector

    _win, area, regions = ui()
    arm = bpy.data.objects[ARMATURE]
    target = bpy.data.objects[TARGET].matrix_world.translation
    mod = sys.modules["reach_addon"]
    info = mod.blender.rig.build(arm, "right")
    shoulder = Vector(info.joints_world["shoulder"].tolist())
    r3d = area.spaces.active.region_3d
    r3d.view_perspective = "PERSP"
    forward = Vector(info.frame.forward.tolist())
    up = Vector(info.frame.up.tolist())
    # the middle of the reach; further away, lowered to take in more of the figure
    r3d.view_location = (shoulder + target) / 2 - (distance - 2.2) * 0.25 * info.arm.arm_length * up
    # From the front and the reaching side, a little above: the path round the plate shows.
    eye_dir = (0.8 * forward + height * up + 1.0 * Vector(info.frame.right.tolist())).normalized()
    r3d.view_rotation = (-eye_dir).to_track_quat("-Z", "Y")
    r3d.view_distance = distance * info.arm.arm_length
    regions["WINDOW"].tag_redraw()
    note("framed", arm_length=info.arm.arm_length)


# --- running an operator as the panel's button does -------------------------------------------

def watch_running(t0, timeout_s, what):
    """Wait (yielding to the event loop) while Reach runs, looking every 50 ms: the
    progress property at each look, the main panel's and the viewport's draws and the
    seconds up to the last look that saw it running, and the progress the panel drew."""
    props = bpy.context.scene.reach
    n0, v0, k0 = draws("REACH_PT_main"), draws("viewport"), len(drawn_progress)
    progress, running = [], {"seconds": 0.0, "main_draws": 0, "viewport_draws": 0}
    while props.running:
        if time.monotonic() - t0 > timeout_s:
            raise RuntimeError(f"{what} still running after {timeout_s} s")
        progress.append(round(props.progress, 4))
        running = {"seconds": round(time.monotonic() - t0, 3),
                   "main_draws": draws("REACH_PT_main") - n0,
                   "viewport_draws": draws("viewport") - v0}
        yield 0.05
    return {"progress": progress, "running": running,
            "drawn_progress": [round(p, 4) for _t, p, _s in drawn_progress[k0:]]}


def run_modal(op_name, timeout_s):
    """Invoke reach.<op_name> like a button press, then wait until it has finished."""
    props = bpy.context.scene.reach
    t0 = time.monotonic()
    with override():
        result = getattr(bpy.ops.reach, op_name)("INVOKE_DEFAULT")
    note(f"{op_name} invoked", result=sorted(result), running=props.running)
    watched = yield from watch_running(t0, timeout_s, f"reach.{op_name}")
    note(f"{op_name} done", seconds=round(time.monotonic() - t0, 2),
         status=props.status, has_result=bool(props.last_result), **watched)


def settle(panel, redraws=4, timeout_s=8.0):
    """Let the sidebar redraw a few times after ``panel`` appeared (as it does while the
    pointer moves over it): Blender slides a new panel into place over several redraws."""
    t0, n0 = time.monotonic(), draws(panel)
    while draws(panel) < n0 + redraws and time.monotonic() - t0 < timeout_s:
        ui()[2]["UI"].tag_redraw()
        yield 0.3


def session():
    win, area, regions = ui()
    props = bpy.context.scene.reach
    props.armature = bpy.data.objects[ARMATURE]
    props.target = bpy.data.objects[TARGET]
    props.arm = "RIGHT"
    for ob in bpy.context.view_layer.objects:       # nothing selected: no outlines in the view
        ob.select_set(False)
    note("start", geometry=geometry(), addon="reach_addon" in bpy.context.preferences.addons,
         panel_registered=hasattr(bpy.types, "REACH_PT_main"),
         uiblocks_offset=drawn_text.sdna_offset("ARegion", "uiblocks"))
    frame_the_arm()
    area.spaces.active.show_region_ui = True
    yield 1.0
    screenshot("sidebar_first_tab")

    # 1. The Reach tab: wheel over the tab strip at the sidebar's outer edge.
    _win, _area, regions = ui()
    turns = yield from reach_tab(lambda: draws("REACH_PT_main"))
    note("reach tab", wheel_turns=turns, main_draws=draws("REACH_PT_main"),
         where=seen["draws"].get("REACH_PT_main", {}).get("where"))
    xdotool("mousemove", *to_screen(regions["WINDOW"], 0.3, 0.3))   # pointer into the view
    yield 1.0
    screenshot("before")

    # 2. Esc cancels a long bake, leaving the scene, the user's keys and undo as they were.
    # The user's own keys (one undo step of theirs) on the bone the bake would key, inside
    # the frames it would key.
    with override():
        bpy.ops.ed.undo_push(message="Reach test: set up")
    clean = state()
    arm = bpy.data.objects[ARMATURE]
    mod = sys.modules["reach_addon"]
    pb = arm.pose.bones[mod.blender.rig.build(arm, "right").bones.arms["right"].keyed("upper_arm")]
    path = "rotation_quaternion" if pb.rotation_mode == "QUATERNION" else "rotation_euler"
    for frame in (1, 15):
        pb.keyframe_insert(path, frame=frame)
    with override():
        bpy.ops.ed.undo_push(message="Reach test: the user's keys")
    before = state()
    settings = props.settings
    saved = settings.step, settings.node_budget, settings.stall_budget
    settings.step, settings.node_budget, settings.stall_budget = 0.004, 200000, 200000
    # searched straight at the plate, not through the guiding nodes (which reach the cup
    # in about as many positions as its path holds): the plan then runs for many seconds,
    # and here and in step 3 there is time to see it running
    settings.guide_when_blocked = False
    yield 1.0          # the interface draws what the keys and settings changed, as it would
    with override():   # before the user's next click
        result = bpy.ops.reach.bake("INVOKE_DEFAULT")
    note("long bake invoked", result=sorted(result), running=props.running)
    n0, v0, k0, t0 = draws("REACH_PT_main"), draws("viewport"), len(drawn_progress), time.monotonic()
    yield 1.5
    running = {"running": props.running, "progress": props.progress, "status": props.status,
               "seconds": round(time.monotonic() - t0, 3),
               "main_draws": draws("REACH_PT_main") - n0, "viewport_draws": draws("viewport") - v0,
               "drawn_progress": [round(p, 4) for _t, p, _s in drawn_progress[k0:]]}
    xdotool("mousemove", *to_screen(regions["WINDOW"], 0.3, 0.3), "key", "Escape")
    t0 = time.monotonic()
    while props.running and time.monotonic() - t0 < 20:
        yield 0.02
    yield 1.0                                    # and nothing lands later
    after = state()
    diff = sorted(k for k in before if before[k] != after[k])
    note("escape", before_escape=running, running_after=props.running,
         seconds_to_stop=round(time.monotonic() - t0, 2), status=props.status, changed=diff,
         before_keys=len(before["keys"]), after_keys=len(after["keys"]),
         before_action=before["armature_action"], after_action=after["armature_action"])
    # Undo after Esc: the top step is still the user's keys (the cancelled bake pushed
    # none), so one Ctrl+Z takes them away and Ctrl+Shift+Z brings them back.
    with override():
        bpy.ops.ed.undo()
    undone = state()
    with override():
        bpy.ops.ed.redo()
    redone = state()
    with override():
        bpy.ops.ed.undo()                        # on without the user's keys
    note("undo after escape", clean_keys=len(clean["keys"]), undone_keys=len(undone["keys"]),
         undone_vs_clean=sorted(k for k in clean if clean[k] != undone[k]),
         redone_keys=len(redone["keys"]),
         redone_vs_before=sorted(k for k in before if before[k] != redone[k]))
    props = bpy.context.scene.reach              # undo replaced the scene's data
    settings = props.settings
    settings.step, settings.node_budget, settings.stall_budget = saved

    # 3. Plan, then Bake; with STEP set in the panel's settings if given (a coarser step
    # shortens the search).
    if STEP is not None:
        settings.step = STEP
    # still searched straight at the plate (step 2): Plan and Bake run for seconds, long
    # enough to watch their progress rise in the panel
    settings.guide_when_blocked = False
    yield 1.0
    yield from run_modal("plan", 120)
    yield from settle("REACH_PT_result")
    planned = state()
    note("planned", trajectory="Reach Trajectory" in bpy.data.objects, keys=len(planned["keys"]),
         trajectory_px=trajectory_on_screen(), scale=scale_on_screen(),
         result=json.loads(props.last_result or "{}"))
    screenshot("planned")

    yield 1.0
    yield from run_modal("bake", 120)
    yield from settle("REACH_PT_result")
    baked = state()
    note("baked", keys=len(baked["keys"]), action=baked["armature_action"],
         result=json.loads(props.last_result or "{}"))
    screenshot("baked")
    bpy.context.scene.frame_set(json.loads(props.last_result)["tasks"][0]["frame_end"])
    yield 1.5
    screenshot("reached")

    # 5. The README's picture (``tools/docs.py`` crops it to the viewport): the character
    # mid-reach, the whole reach in view, the Result panel open.
    task = json.loads(props.last_result)["tasks"][0]
    bpy.context.scene.frame_set(round(task["frame_start"] + 0.6 * (task["frame_end"] - task["frame_start"])))
    frame_the_arm(distance=3.4, height=0.4)
    area.spaces.active.overlay.show_bones = False      # the figure, not its armature's bones
    yield 1.5
    screenshot("readme", redraws=2)

    # 6. Every label of every Reach panel, as drawn at the sidebar's default width.
    yield from every_label()


timer_session.drive(session(), seen, OUT, DEADLINE_S)
