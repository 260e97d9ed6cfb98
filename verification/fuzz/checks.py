"""The fuzz campaign's checks: bake a built scene as a user does and classify the outcome.

:func:`bake_argv` is the scene's ``reach bake`` command line and :func:`run_cli` runs it
in-process; :func:`keyed_values` reads a baked file's keys as raw bytes (two bakes must
match byte for byte); :func:`verify` is the independent check of every successful task
(Blender's evaluated bones at every frame and sub-frame instant against the evaluated
obstacle triangles, :func:`verification.clearance.independent_check`); :func:`classify`
gives the scene one outcome of :data:`CATEGORIES`, and :func:`cross_check` checks its
refusals (:mod:`verification.refusal`). The categories and why the check is built so:
``docs/design.md``, *The fuzz campaign*.
"""

from __future__ import annotations

import hashlib
import traceback
from pathlib import Path

import numpy as np

from .. import rig_builders
from ..clearance import independent_check
from .building import translation

#: Every outcome, in the order fuzz.json lists them, with what it means.
CATEGORIES = {
    "success_verified": "every task reached; clear at every frame and sub-frame instant and "
                        "the wrist on the target (independent check)",
    "failure_with_reason": "a task failed with a documented reason, or the input was refused "
                           "(exit 2) with a message naming what is wrong",
    "escaped_exception": "an exception escaped the command (or the process died)",
    "timeout": "the scene did not finish within the time limit",
    "success_but_collides": "reported success, but the independent check finds arm or hand "
                            "touching an obstacle at some instant",
    "success_off_target": "reported success, but the wrist is not on the target on the last "
                          "frame",
    "success_turns_too_fast": "reported success, but a bone of the hand turns faster in "
                              "space from one frame to the next than the hand's bound, on "
                              "more frames than the report says it lifted the bound",
    "rig_off_target": "a task failed as rig_off_target: Reach's own check found that its keys "
                      "put the wrist off the target as Blender evaluates them (a fault of "
                      "Reach's reading of the rig, reported honestly)",
    "input_changed": "the input file (or a library it links) changed",
    "nondeterministic": "two bakes of the same file keyed different values or ended "
                        "differently",
    "unclear_failure": "a failure without a documented reason, or a refusal that does not "
                       "name the object at fault",
    "generator_error": "the fuzz harness itself failed to build or check the scene (not "
                       "Reach)",
    "false_refusal": "a task failed with a reason that the independent cross-check "
                     "contradicts (a clear path exists, or the start's arm and hand skin are "
                     "clear)",
}
GOOD = ("success_verified", "failure_with_reason")

#: Sub-frame instants checked between two frames (besides the frames themselves).
SUBFRAMES = 3
#: Seconds the cross-check's OMPL search may take per refusal where a goal region exists
#: (``verification.refusal``; ``--cross-check-budget``).
CROSS_CHECK_BUDGET_S = 10.0


def bake_argv(spec: dict, manifest: dict, output: Path, report: Path) -> list:
    """The command line of the scene: ``reach bake INPUT --armature ... --output ...``."""
    argv = ["bake", manifest["input"], "--armature", manifest["armature"]]
    for t in manifest["targets"]:
        argv += ["--target", t["name"]]
    argv += ["--task", spec["task"], "--arm", spec["arm"]]
    if spec["frame_start_flag"] is not None:
        argv += ["--frame-start", str(spec["frame_start_flag"])]
    if spec["bake_closest"]:
        argv.append("--bake-closest")
    if spec["new_action"]:
        argv.append("--new-action")
    if spec["no_chest_rotation"]:
        argv.append("--no-chest-rotation")
    if spec["duration"] is not None:
        argv += ["--duration", f"{spec['duration']:.3f}"]
    if spec["obstacle_collection"]:
        argv += ["--obstacles", "FzObstacles"]
    for name, value in sorted(spec["settings"].items()):
        flag = "--" + name.replace("_", "-")
        argv += [flag] if value is True else [f"--no-{name.replace('_', '-')}"] \
            if value is False else [flag, str(value)]
    return argv + ["--output", str(output), "--report", str(report)]


def run_cli(argv: list) -> dict:
    """``reach_addon.cli.main(argv)`` in this process, its output captured; an exception
    that leaves it is caught here and kept with its traceback."""
    import contextlib
    import io
    import warnings

    from reach_addon import cli

    out, err = io.StringIO(), io.StringIO()
    exc = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")     # the same warnings on every run, kept apart
        try:
            rc = cli.main(argv)
        except Exception:   # noqa: BLE001  (every escaping exception is a finding)
            rc, exc = None, traceback.format_exc()
    notes = sorted({f"{Path(w.filename).name}:{w.lineno}: {w.category.__name__}: {w.message}"
                    for w in caught})
    return {"rc": rc, "stdout": out.getvalue(), "stderr": err.getvalue(), "exception": exc,
            "warnings": notes}


def digest(path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def keyed_values() -> list:
    """Every key of every action of the open file, as raw bytes: (action, data path,
    index, bytes of the float32 frames, values and handles and the interpolations)."""
    import bpy

    rigs, _synthetic = rig_builders()
    out = []
    for action in sorted(bpy.data.actions, key=lambda a: a.name):
        for fc in rigs.fcurves(action):
            pts = fc.keyframe_points
            n = len(pts)
            parts = []
            for attr in ("co", "handle_left", "handle_right"):
                a = np.empty(2 * n, dtype=np.float32)
                pts.foreach_get(attr, a)
                parts.append(a.tobytes())
            interp = np.empty(n, dtype=np.int32)
            pts.foreach_get("interpolation", interp)
            parts.append(interp.tobytes())
            out.append((action.name, fc.data_path, fc.array_index, b"".join(parts)))
    return out


def _mesh_triangles(mesh, matrix) -> np.ndarray:
    mesh.calc_loop_triangles()
    n_v, n_t = len(mesh.vertices), len(mesh.loop_triangles)
    if n_t == 0:
        return np.zeros((0, 3, 3))
    co = np.empty(n_v * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    idx = np.empty(n_t * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", idx)
    m = np.asarray(matrix, dtype=float)
    world = co.reshape(-1, 3).astype(float) @ m[:3, :3].T + m[:3, 3]
    return world[idx.reshape(-1, 3)]


def solid_triangles(names, min_area: float) -> np.ndarray:
    """World triangles (T, 3, 3) of the named obstacles as Blender evaluates them now
    (modifiers applied; a collection instance's objects under its instancer); triangles
    of less than ``min_area`` are left out (no surface to touch)."""
    import bpy

    depsgraph = bpy.context.evaluated_depsgraph_get()
    parts = [np.zeros((0, 3, 3))]
    for name in names:
        ob = bpy.data.objects[name]
        if ob.instance_type == "COLLECTION" and ob.instance_collection is not None:
            coll = ob.instance_collection
            base = np.array(ob.evaluated_get(depsgraph).matrix_world) @ translation(
                -np.array(coll.instance_offset))
            for inner in coll.all_objects:
                if inner.type == "MESH":
                    parts.append(_mesh_triangles(inner.data, base @ np.array(inner.matrix_world)))
            continue
        ev = ob.evaluated_get(depsgraph)
        mesh = ev.to_mesh()
        try:
            parts.append(_mesh_triangles(mesh, np.array(ev.matrix_world)))
        finally:
            ev.to_mesh_clear()
    tris = np.concatenate(parts)
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    return tris[area > min_area]


class ArmReader:
    """The reaching arm's five joints at the current evaluation, followed by the ends of the
    hand shape's capsules where the rig model has one: each is carried by its bone (read
    from the rig model in the start pose: sternum by the clavicle, or the chest without
    one; the hand's far end and the shape by the hand)."""

    def __init__(self, armature, info):
        from reach_addon.blender import rig as rig_mod

        bones = info.bones.arms[info.side]
        self.names = (bones.clavicle or info.bones.chest, bones.upper_arm, bones.forearm,
                      bones.hand)
        sternum = info.arm.to_world_points(np.asarray(info.arm.sternum, dtype=float))
        group = getattr(info, "hand_bones", None) or None
        axis, _l, _s = rig_mod.hand_shape(armature, bones.hand, info.arm.forearm_length,
                                          **({"group": group} if group else {}))
        mats = self._matrices(armature)
        tip = mats[3][:3, 3] + axis * info.arm.hand_length
        self.sternum_local = np.linalg.solve(mats[0], np.append(sternum, 1.0))
        self.tip_local = np.linalg.solve(mats[3], np.append(tip, 1.0))
        # the ends of the hand shape's capsules (what the planner keeps clear of the hand:
        # reach_addon.core.hand_shape) on the model's start pose, carried by the hand bone
        self.shape_local = np.zeros((0, 4))
        if info.arm.hand_shape:
            from reach_addon.core.arm import pose_from_config
            from reach_addon.core.hand_shape import world_pose

            start = pose_from_config(info.arm, info.start, hand=info.start_hand)
            ends = world_pose(info.arm, start)[5:]
            self.shape_local = np.linalg.solve(mats[3], np.column_stack(
                [ends, np.ones(len(ends))]).T).T

    def _matrices(self, armature):
        mw = np.array(armature.matrix_world)
        return [mw @ np.array(armature.pose.bones[n].matrix) for n in self.names]

    def joints(self, armature) -> np.ndarray:
        anchor, upper, fore, hand = self._matrices(armature)
        joints = np.array([(anchor @ self.sternum_local)[:3], upper[:3, 3], fore[:3, 3],
                           hand[:3, 3], (hand @ self.tip_local)[:3]])
        if not len(self.shape_local):
            return joints
        return np.vstack([joints, (self.shape_local @ hand.T)[:, :3]])


def verify(manifest: dict, report: dict, output: Path, subframes: int) -> list:
    """The independent check of every successful, baked task of ``report`` in ``output``;
    returns the problems found: [(category, one line)]."""
    import bpy

    from reach_addon.blender import rig as rig_mod

    tasks = [t for t in report["tasks"] if t["success"] and t["bones_keyed"]]
    if not tasks:
        return []
    first = min(t["frame_start"] for t in report["tasks"])
    # the rig model (radii, the hand), from the input as the bake read it
    bpy.ops.wm.open_mainfile(filepath=manifest["input"], load_ui=False)
    scene = bpy.context.scene
    scene.frame_set(first)
    arm = bpy.data.objects[manifest["armature"]]
    info = rig_mod.build(arm, report["arm"])
    reader = ArmReader(arm, info)
    length = info.arm.arm_length
    start_positions = {t["name"]: np.array(bpy.data.objects[t["name"]].matrix_world.translation)
                       for t in manifest["targets"]}
    refs = {t["name"]: t["ref"] for t in manifest["targets"]}

    bpy.ops.wm.open_mainfile(filepath=str(output), load_ui=False)
    scene = bpy.context.scene
    arm = bpy.data.objects[manifest["armature"]]
    movers = set(manifest["movers"])
    min_area = 1e-10 * length * length
    static = None
    problems = []
    horizon = 0.05 * length
    tolerance = (0.005 + 1e-4) * length
    hand = bool(report.get("settings", {}).get("check_hand", True))   # off: the user's choice
    turn_bound = hand_turn_bound(report, scene)
    hand_bones = list(getattr(info, "hand_bones", None) or (info.bones.arms[info.side].hand,))
    for task in tasks:
        fa, fb = int(task["frame_start"]), int(task["frame_end"])
        instants = [(f, k / (subframes + 1)) for f in range(fa, fb) for k in range(subframes + 1)]
        instants.append((fb, 0.0))
        leaving = True           # a start in contact may stay in contact only while leaving it
        touching = []            # (instant, part, depth) after the first clear instant
        turns = HandTurns(arm, hand_bones, turn_bound)
        for f, sub in instants:
            scene.frame_set(f, subframe=sub)
            if sub == 0.0:
                turns.at(f)
            if static is None:
                static = solid_triangles([n for n in manifest["solids"] if n not in movers], min_area)
            tris = static
            if movers:
                tris = np.concatenate([static, solid_triangles(sorted(movers), min_area)])
            joints = reader.joints(arm)
            hits, arm_hits, least = independent_check(info.arm, joints[None], tris, hand, horizon)
            if not hits:
                leaving = False
            elif not leaving:
                touching.append((f + sub, "arm" if arm_hits else "hand", -least / length))
        if touching:
            at, part, depth = max(touching, key=lambda x: x[2])
            problems.append(("success_but_collides",
                             f"'{task['target']}': {len(touching)} instant(s) from frame "
                             f"{touching[0][0]:.2f} to {touching[-1][0]:.2f} touching, the "
                             f"deepest the {part} {depth:.4f} arm lengths in at frame {at:.2f}"))
        lifted = int(task.get("unbounded_hand_turns") or 0)
        if len(turns.over) > lifted:
            at, turn = max(turns.over, key=lambda x: x[1])
            problems.append(("success_turns_too_fast",
                             f"'{task['target']}': the hand turns more than "
                             f"{turn_bound:.2f}° a frame into {len(turns.over)} frame(s) "
                             f"(the report lifts the bound on {lifted}), {turn:.2f}° into "
                             f"frame {at}"))
        scene.frame_set(fb)
        wrist = reader.joints(arm)[3]
        name = task["target"]
        goal = (start_positions[name] if refs.get(name, "start") == "start"
                else np.array(bpy.data.objects[name].matrix_world.translation))
        gap = float(np.linalg.norm(wrist - goal))
        if not gap <= tolerance:
            problems.append(("success_off_target",
                             f"'{name}': the wrist is {gap / length:.4f} arm lengths from the "
                             f"target at frame {fb}"))
    return problems


#: How far (degrees) a measured turn may exceed the bound: float32 round-off in Blender's
#: matrices (the planner's turns at the bound measure 14.99°–15.00° on the bones).
TURN_ROUNDING = 0.01


def hand_turn_bound(report: dict, scene) -> float:
    """The most a bone of the hand may turn in space from one frame to the next (degrees):
    the bake's ``hand_space_turn_speed`` at the scene's frame rate, with the round-off
    allowed."""
    speed = float(report.get("settings", {}).get("hand_space_turn_speed", 360.0))
    return speed / (scene.render.fps / scene.render.fps_base) + TURN_ROUNDING


class HandTurns:
    """The hand bones' whole world rotation, frame to frame (the angle of R_prevᵀ R, the
    bone's roll included), as Blender evaluates them: ``over`` lists (frame, degrees) of
    the frames into which some bone turned more than ``bound``; ``worst`` is (degrees,
    frame) of the largest turn (-1, None before two frames)."""

    def __init__(self, armature, bones, bound: float):
        self.armature, self.bones, self.bound = armature, list(bones), bound
        self.previous = None
        self.over: list = []
        self.worst = (-1.0, None)

    def _rotations(self):
        mw = np.array(self.armature.matrix_world)[:3, :3]
        out = []
        for name in self.bones:
            m = mw @ np.array(self.armature.pose.bones[name].matrix)[:3, :3]
            out.append(m / np.linalg.norm(m, axis=0))
        return out

    def at(self, frame: int) -> None:
        """Measure the turn into ``frame`` (the scene evaluated there)."""
        now = self._rotations()
        if self.previous is not None:
            turn = max(float(np.degrees(np.arccos(np.clip((np.trace(a.T @ b) - 1.0) / 2.0,
                                                             -1.0, 1.0))))
                       for a, b in zip(self.previous, now))
            if turn > self.bound:
                self.over.append((frame, turn))
            self.worst = max(self.worst, (turn, frame))
        self.previous = now


_REPORT_KEYS = ("target", "arm", "success", "reason", "message", "frame_start", "frame_end",
                "bones_keyed", "nodes_searched", "nodes_in_solution", "frames")


def _essentials(run: dict):
    report = run.get("report")
    tasks = None
    if report is not None:
        tasks = [{k: t.get(k) for k in _REPORT_KEYS} for t in report["tasks"]]
    return run["rc"], run["stderr"].strip(), tasks


def _refusal(stderr: str) -> str:
    lines = [line for line in stderr.strip().splitlines() if line.startswith("reach: ")]
    return lines[-1][len("reach: "):] if lines else ""


def classify(spec: dict, manifest: dict, runs: list, changed: list, keys: list,
             problems: list) -> tuple:
    """(category, one line) of a scene from its two runs; the worst finding wins."""
    from reach_addon.core import REASONS

    for run in runs:
        if run["exception"]:
            last = run["exception"].strip().splitlines()[-1]
            return "escaped_exception", last
    if changed:
        return "input_changed", f"{', '.join(Path(c).name for c in changed)} changed"
    first, second = _essentials(runs[0]), _essentials(runs[1])
    if first != second:
        what = "exit status" if first[0] != second[0] else "message" if first[1] != second[1] \
            else "report"
        if what == "report" and first[2] and second[2] and len(first[2]) == len(second[2]):
            what = next(f"report '{k}' ({a[k]!r} vs {b[k]!r})" for a, b in zip(first[2], second[2])
                        for k in a if a[k] != b[k])
        return "nondeterministic", f"the two bakes ended differently: {what}"
    if keys[0] != keys[1]:
        differ = next((a[1], a[2]) for a, b in zip(keys[0], keys[1]) if a != b) \
            if len(keys[0]) == len(keys[1]) else ("count", len(keys[0]) - len(keys[1]))
        return "nondeterministic", f"the two bakes keyed different values ({differ[0]}[{differ[1]}])"
    for category in ("success_but_collides", "success_off_target", "success_turns_too_fast"):
        for c, line in problems:
            if c == category:
                return c, line
    rc = runs[0]["rc"]
    if rc == 2:
        message = _refusal(runs[0]["stderr"])
        if not message:
            return "unclear_failure", "exit 2 without a message"
        # The message names an object of the scene; where the scene has a fault of its
        # own, the object at fault (or the armature, whose problems are found first).
        wanted = manifest["culprits"] + [manifest["armature"]] if manifest["must_refuse"] \
            else manifest["names"]
        if not any(c in message for c in wanted):
            return "unclear_failure", f"refused without naming {wanted}: {message}"
        return "failure_with_reason", f"bad_input: {message}"
    report = runs[0]["report"]
    if rc not in (0, 1) or report is None:
        return "unclear_failure", f"exit status {rc}"
    failed = [t for t in report["tasks"] if not t["success"]]
    for t in failed:
        if t["reason"] not in REASONS or not t["message"]:
            return "unclear_failure", f"'{t['target']}' failed with reason {t['reason']!r}"
    if (rc == 0) != (not failed):
        return "unclear_failure", f"exit status {rc} with {len(failed)} failed task(s)"
    if manifest["must_refuse"]:
        return "unclear_failure", f"bad input accepted (expected a refusal naming {manifest['culprits']})"
    for t in failed:
        if t["reason"] == "rig_off_target":
            return "rig_off_target", t["message"]
    if failed:
        t = failed[0]
        return "failure_with_reason", f"{t['reason']}: {t['message']}"
    return "success_verified", f"{len(report['tasks'])} task(s) reached and verified"


def cross_check(spec: dict, manifest: dict, report: dict, budget_s: float) -> list:
    """Every refusal of ``report`` (the first bake's) cross-checked on the scene's input
    file by :func:`verification.refusal.check_report`: OMPL's search where a goal region
    exists (``budget_s`` seconds; on a quick scene also at most the scene's own sampling
    budget of states, the budget its starved planner had), the skin for a start in
    collision. Returns the verdicts as plain data (one per failed task)."""
    import bpy

    from .. import refusal

    bpy.ops.wm.open_mainfile(filepath=manifest["input"], load_ui=False)
    max_states = spec["settings"].get("sampling_budget") if spec.get("quick") else None
    verdicts = refusal.check_report(
        bpy.context, report, spec["task"], "FzObstacles" if spec["obstacle_collection"] else None,
        budget_s=budget_s, max_states=max_states, seed=spec["seed"])
    return [v.to_dict() for v in verdicts]
