"""``make bench``: where Reach stands — a benchmark, not a test (nothing here asserts).

Every figure is the median of ``--runs`` (default 5) runs with its spread (min–max), written
to ``bench/results.json`` and a readable ``bench/results.md``:

1. **Table 2**: the paper's four tasks on the demo workplace (:data:`reach_addon.demo.WORKPLACE`,
   the core's standard figure; ``make demo`` plans the same tasks with a real character in
   Blender), each timed from a fresh planner: search time, grid preprocessing (the
   workspace, built once per planner, as the paper's), nodes searched / in solution, path
   length, time per node and the speed-up over the paper's times.
   **Table 1**: reaches baked over directions at both rows of Table 1 on the demo
   character, the chest's turn at arrival read from the evaluated bones and plotted against
   the table (``bench/table1.png``, :mod:`bench.table1`).
2. **OMPL race** (:mod:`verification.race`): RRTConnect + simplification in the same joint
   space with the same collision test, start and goal region, at least 20 seeds a task,
   Reach's grid inside its time, both paths held to one independent check.
3. **Chase / live re-plan**: time per target update (:mod:`bench.live_bench`); **reach
   envelope**: the standard figure's 2,197-point envelope in the demo workplace.
4. **Bake**: 1000 frames written in bulk on the metarig's keyed bones; **obstacle
   scaling**: the collision-free task with the table top tessellated to 5k, 100k and 1M
   triangles (search time and BVH build time); **gather**: obstacles read from a
   geometry-nodes scatter of 10,000 instances in front of a real character. **GUI
   latency** (:mod:`bench.gui_latency`): Plan's wall time in Blender 3.4.1's interface
   under Xvfb against the same plan headless, on the GUI test's plate scene.
5. **Batch throughput**: a 200-task study on 1 and 2 local worker processes (one run each:
   it takes minutes).
6. **Tight scenes** (:mod:`bench.tight`, issue 14): 240 generated cubbies, slots, holes and
   gaps sized to six arms' limb thickness; OMPL (20 s a scene) says which have a path, and
   the table gives Reach's share of those (goal ≥ 99 %) and both median times; per scene in
   ``bench/tight.json`` (one run: it takes most of an hour).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402,F401  (mathutils and the BVH come with the wheel)

from reach_addon import __version__  # noqa: E402
from reach_addon.core import Planner, Settings, Task  # noqa: E402
from reach_addon.core.collision import Obstacles  # noqa: E402
from reach_addon.demo import PAPER_TABLE2, WORKPLACE, demo_tasks  # noqa: E402
from reach_addon.samples import obstacles, standard_arm, triangle_soup  # noqa: E402

TASKS = ("collision_free", "rotation", "guided", "chase")


def spread(values):
    v = [float(x) for x in values]
    return {"median": statistics.median(v), "min": min(v), "max": max(v), "runs": len(v)}


def log(*args):
    print(*args, flush=True)


# --- 1. Table 2 ------------------------------------------------------------------------------

def table2(runs: int):
    out = []
    tasks = dict(demo_tasks())
    for name in TASKS:
        samples = []
        for _ in range(runs):
            planner = Planner(standard_arm(), obstacles(WORKPLACE), Settings())
            t0 = time.perf_counter()
            ws = planner.workspace          # the grid: preprocessing, once per planner
            prep = time.perf_counter() - t0
            plan = planner.plan(tasks[name])
            s = plan.stats
            samples.append((s.search_time_s, prep, s.nodes_searched, s.nodes_in_solution,
                            s.path_length_arm_lengths, plan.success, s.planning_time_s, s))
            del ws
        search = [x[0] for x in samples]
        paper_t, paper_n, paper_k, paper_len = PAPER_TABLE2[name]
        med = statistics.median(search)
        row = {
            "task": name, "success": all(x[5] for x in samples),
            "search_time_s": med, "search_time_spread_s": spread(search),
            "preprocess_time_s": statistics.median(x[1] for x in samples),
            "nodes_searched": samples[0][2], "nodes_in_solution": samples[0][3],
            "path_length_arm_lengths": samples[0][4],
            "time_per_node_ms": 1000 * med / max(samples[0][2], 1),
            "paper_search_time_s": paper_t, "paper_nodes_searched": paper_n,
            "paper_nodes_in_solution": paper_k, "paper_path_length_arm_lengths": paper_len,
            "speedup_vs_paper": paper_t / med if med else None,
            "deterministic": len({x[2:5] for x in samples}) == 1,
            # the whole plan (search, smoothing, timing, the hand pass), and the hand
            "planning_time_s": statistics.median(x[6] for x in samples),
            "planning_time_spread_s": spread([x[6] for x in samples]),
            "frames": samples[0][7].frames,
            "max_wrist_turn_deg_per_frame": samples[0][7].max_wrist_turn_deg_per_frame,
            "max_hand_turn_deg_per_frame": samples[0][7].max_hand_turn_deg_per_frame,
            "mean_wrist_bend_deg": samples[0][7].mean_wrist_bend_deg,
            "max_wrist_bend_deg": samples[0][7].max_wrist_bend_deg,
            "chicken_wing_frames": samples[0][7].chicken_wing_frames,
            "mean_f_r": samples[0][7].mean_f_r,
            "inserted_frames": samples[0][7].inserted_frames,
            "unbounded_hand_turns": samples[0][7].unbounded_hand_turns,
            "touching_transitions": samples[0][7].touching_transitions,
        }
        out.append(row)
        log(f"  {name:15s} {1000 * med:8.1f} ms (paper {1000 * paper_t:.0f} ms, "
            f"{row['speedup_vs_paper']:.0f}×), {row['nodes_searched']} nodes (paper {paper_n})")
    return out


# --- 1b. Table 1 -----------------------------------------------------------------------------

def table1():
    """The chest's turn at arrival on the demo character against Table 1, and the plot."""
    from bench import table1 as sweep

    result = sweep.main(ROOT / "bench")
    log(f"  {result['reached']}/{result['reaches']} reached; largest difference from Table 1 "
        f"{result['max_abs_error_deg']:.2f}°; wrote bench/table1.png")
    return {"table1": result}


# --- 2. OMPL --------------------------------------------------------------------------------

#: Least number of OMPL seeds raced per task (a randomised planner needs many runs).
RACE_RUNS = 20


def ompl(runs: int):
    """The race on every task with at least :data:`RACE_RUNS` OMPL seeds, a fresh planner
    each (the grid inside Reach's time where the task builds it): medians and spread; the
    time and length ratios over the runs where both paths pass the independent check;
    both planners' BVH queries counted on seed 0."""
    try:
        from verification import race
    except ImportError as exc:
        log(f"  OMPL race skipped: {exc} (pip install -r requirements-bench.txt)")
        return []
    tasks = dict(demo_tasks())
    out = []
    for name in TASKS:
        results = []
        for seed in range(max(runs, RACE_RUNS)):
            planner = Planner(standard_arm(), obstacles(WORKPLACE), Settings())
            results.append(race.race(name, planner, tasks[name], seed=seed,
                                     count_queries=seed == 0))
        keys = ("reach_time_s", "ompl_time_s", "reach_path_length", "ompl_path_length",
                "reach_mean_f_r", "ompl_mean_f_r", "reach_collisions", "ompl_collisions",
                "reach_arm_collisions", "ompl_arm_collisions", "ompl_validity_checks",
                "reach_preprocess_time_s")
        row = {"task": name, "runs": len(results)}
        for k in keys:
            row[k] = statistics.median(r[k] for r in results)
            row[k + "_spread"] = spread([r[k] for r in results])
        both = [r for r in results if r["reach_passed"] and r["ompl_passed"]]
        row["reach_passed"] = sum(r["reach_passed"] for r in results)
        row["ompl_passed"] = sum(r["ompl_passed"] for r in results)
        row["both_passed"] = len(both)
        row["time_ratio_ompl_over_reach"] = (
            statistics.median(r["ompl_time_s"] for r in both)
            / statistics.median(r["reach_time_s"] for r in both)) if both else None
        row["path_ratio_reach_over_ompl"] = (
            statistics.median(r["reach_path_length"] for r in both)
            / statistics.median(r["ompl_path_length"] for r in both)) if both else None
        row["reach_nodes_searched"] = results[0]["reach_nodes_searched"]
        row["reach_obstacle_queries"] = results[0]["reach_obstacle_queries"]
        row["ompl_obstacle_queries"] = results[0]["ompl_obstacle_queries"]
        row["note"] = results[0].get("note", "")
        out.append(row)
        ratio = row["time_ratio_ompl_over_reach"]
        log(f"  {name:15s} reach {row['reach_time_s'] * 1000:7.1f} ms / OMPL "
            f"{row['ompl_time_s'] * 1000:7.1f} ms ({len(results)} runs, "
            f"{'–' if ratio is None else f'{ratio:.2f}'}× over {len(both)} passing both); "
            f"length {row['reach_path_length']:.2f} / {row['ompl_path_length']:.2f}; "
            f"f_R {row['reach_mean_f_r']:.2f} / {row['ompl_mean_f_r']:.2f}; collisions "
            f"{row['reach_collisions']} (arm {row['reach_arm_collisions']}) / "
            f"{row['ompl_collisions']} (arm {row['ompl_arm_collisions']}); passed "
            f"{row['reach_passed']} / {row['ompl_passed']}")
    return out


# --- 3. chase updates ---------------------------------------------------------------------------

def chase_updates():
    try:
        from bench import live_bench
    except ImportError as exc:
        log(f"  live re-plan skipped: {exc}")
        return {}
    r = live_bench.chase_update_times()
    log(f"  p50 {r['p50_ms']:.2f} ms, p95 {r['p95_ms']:.2f} ms over {len(r['samples'])} updates")
    return {"chase_update_ms_p50": r["p50_ms"], "chase_update_ms_p95": r["p95_ms"],
            "chase_updates": len(r["samples"])}


# --- 4. bake and obstacle scaling ------------------------------------------------------------------

def bake_1000(runs: int):
    """Bulk-write a 1000-frame plan on Rigify's metarig (chest, shoulder, upper arm,
    forearm, hand: the 5 bones a bake keys there, 4 channels each): the figure is the one
    measured, for the bones the bake really keys (no extrapolation to other counts)."""
    import addon_utils

    from reach_addon.blender import bake as bake_mod
    from reach_addon.blender import rig as rig_mod

    bpy.ops.wm.read_homefile(use_empty=True)
    addon_utils.enable("rigify", default_set=True)
    bpy.ops.object.armature_human_metarig_add()
    bpy.ops.object.mode_set(mode="OBJECT")
    armature = bpy.context.object
    info = rig_mod.build(armature, "right")
    f, length = info.frame, info.arm.arm_length
    target = info.joints_world["shoulder"] + length * (0.7 * f.forward + 0.2 * f.right)
    planner = Planner(info.arm, None, Settings())
    plan = planner.plan(Task("reach", target[None], info.start, 24.0))
    # stretch the plan to 1000 frames (with body rotation so the chest is keyed too)
    idx = np.linspace(0, len(plan.poses) - 1, 1000).round().astype(int)
    plan.poses = [plan.poses[i] for i in idx]
    times = []
    bones = 0
    for _ in range(runs):
        if armature.animation_data:
            armature.animation_data.action = None
        t0 = time.perf_counter()
        result = bake_mod.bake(bpy.context, armature, info, [(plan, 1)])
        times.append(time.perf_counter() - t0)
        bones = len(result.bones)
    ms = 1000 * statistics.median(times)
    log(f"  1000 frames × {bones} bones: {ms:.1f} ms")
    return {"bake_1000_frames_ms": ms, "bake_bones": bones,
            "bake_spread_ms": spread([1000 * t for t in times])}


def tessellated_box(lo, hi, n):
    """A box whose six faces are n × n grids: 12 n² triangles."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    verts, tris = [], []
    g = np.linspace(0, 1, n + 1)
    u, v = np.meshgrid(g, g, indexing="ij")
    quads = np.array([[i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1,
                       i * (n + 1) + j + 1] for i in range(n) for j in range(n)])
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        for side in (0, 1):
            p = np.zeros(((n + 1) ** 2, 3))
            p[:, axis] = hi[axis] if side else lo[axis]
            p[:, a] = lo[a] + u.ravel() * (hi[a] - lo[a])
            p[:, b] = lo[b] + v.ravel() * (hi[b] - lo[b])
            base = sum(len(x) for x in verts)
            verts.append(p)
            tris.append(np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]) + base)
    return np.concatenate(verts), np.concatenate(tris)


def scaling(runs: int):
    task = dict(demo_tasks())["collision_free"]
    parts = dict(WORKPLACE)
    top_lo, top_hi = parts["Table"][0]
    rest = {"Table": parts["Table"][1:], "Crate": parts["Crate"], "Shelf": parts["Shelf"]}
    v0, t0_, _o, _n = triangle_soup(rest)
    out = []
    for wanted in (5_000, 100_000, 1_000_000):
        n = max(1, int(round((wanted / 12) ** 0.5)))
        v, t = tessellated_box(top_lo, top_hi, n)
        verts = np.concatenate([v0, v])
        tris = np.concatenate([t0_, t + len(v0)])
        builds, searches = [], []
        for _ in range(runs):
            t0 = time.perf_counter()
            obs = Obstacles.from_triangles(verts, tris)
            builds.append(time.perf_counter() - t0)
            planner = Planner(standard_arm(), obs, Settings())
            searches.append(planner.plan(task).stats.search_time_s)
        row = {"triangles": int(len(tris)), "search_time_s": statistics.median(searches),
               "bvh_build_time_s": statistics.median(builds),
               "search_spread_s": spread(searches)}
        out.append(row)
        log(f"  {row['triangles']:>9,d} triangles: search {1000 * row['search_time_s']:.1f} ms, "
            f"BVH build {1000 * row['bvh_build_time_s']:.1f} ms")
    return out


def gather_scatter(runs: int):
    """Obstacle gathering from a geometry-nodes scatter: 10,000 unrealized cube instances
    on a 100 × 100 grid one arm length wide, half an arm length in front of a real
    character's reaching shoulder (Quaternius; ``tests/blender/obstacle_scene.py``)."""
    sys.path.insert(0, str(ROOT / "tests" / "blender"))
    import obstacle_scene
    import rigs

    from reach_addon.blender import rig as rig_mod
    from reach_addon.blender.scene import character_objects, gather_obstacles

    arm = rigs.load("quaternius")
    rigs.rest_still(arm)
    info = rig_mod.build(arm, "right")
    length = info.arm.arm_length
    centre = info.joints_world["shoulder"] + 0.5 * length * info.frame.forward
    matrix = np.eye(4)
    matrix[:3, :3] = np.column_stack([info.frame.right, info.frame.up, -info.frame.forward])
    matrix[:3, 3] = centre
    spacing = length / 100
    obstacle_scene.add_gn_instances("Scatter", matrix, obstacle_scene.grid_points(100, spacing),
                                    0.5 * spacing)
    bpy.context.view_layer.update()
    exclude = character_objects(arm, bpy.context.scene)
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        obs = gather_obstacles(bpy.context, exclude)
        times.append(time.perf_counter() - t0)
    counts = dict(obs.triangle_counts())
    log(f"  10,000 instances, {obs.triangle_count:,d} triangles ({counts}): gather "
        f"{1000 * statistics.median(times):.0f} ms")
    return {"gather_10k_instances_ms": 1000 * statistics.median(times),
            "gather_10k_instances_spread_s": spread(times),
            "gather_10k_instances_triangles": obs.triangle_count}


def _grid_object(name, n, matrix=None, mesh=None):
    """A mesh object of an n × n grid of quads (2 n² triangles) one unit wide, gently
    waved, or an object sharing ``mesh``."""
    from mathutils import Matrix

    if mesh is None:
        xs = np.linspace(-0.5, 0.5, n + 1)
        x, y = np.meshgrid(xs, xs, indexing="ij")
        co = np.column_stack([x.ravel(), y.ravel(),
                              (0.02 * np.sin(20 * x) * np.cos(17 * y)).ravel()])
        a = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
        quads = np.column_stack([a, a + n + 1, a + n + 2, a + 1]).astype(np.int32)
        mesh = bpy.data.meshes.new(name)
        mesh.vertices.add(len(co))
        mesh.vertices.foreach_set("co", co.astype(np.float32).ravel())
        mesh.loops.add(quads.size)
        mesh.loops.foreach_set("vertex_index", quads.ravel())
        mesh.polygons.add(len(quads))
        mesh.polygons.foreach_set("loop_start", np.arange(0, quads.size, 4, dtype=np.int32))
        mesh.update()
    ob = bpy.data.objects.new(name, mesh)
    if matrix is not None:
        ob.matrix_world = Matrix(np.asarray(matrix).tolist())
    bpy.context.scene.collection.objects.link(ob)
    return ob


def blender_builds(ob, runs: int) -> dict:
    """Blender's own BVH builders on one mesh object, alone (ms, spread): the floor under
    any way of making its obstacles ready. ``FromObject`` (the evaluated mesh, in the
    object's own space), ``FromBMesh`` (a BMesh read from the mesh; reading included) and
    ``FromPolygons`` (world-space lists, made before the clock: the build alone)."""
    import bmesh
    from mathutils.bvhtree import BVHTree

    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = ob.evaluated_get(depsgraph).data
    mesh.calc_loop_triangles()
    n = len(mesh.vertices)
    co = np.empty(3 * n)
    mesh.vertices.foreach_get("co", co)
    m = np.array(ob.matrix_world)
    world = (co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]).tolist()
    tris = np.empty(3 * len(mesh.loop_triangles), dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", tris)
    tris = tris.reshape(-1, 3).tolist()

    def from_bmesh():
        bm = bmesh.new()
        bm.from_mesh(mesh)
        BVHTree.FromBMesh(bm)
        bm.free()

    builders = {"FromObject": lambda: BVHTree.FromObject(ob, depsgraph),
                "FromBMesh": from_bmesh,
                "FromPolygons": lambda: BVHTree.FromPolygons(world, tris, all_triangles=True)}
    out = {}
    for name, build in builders.items():
        times = []
        for _ in range(runs):
            t0 = time.perf_counter()
            build()
            times.append(1000 * (time.perf_counter() - t0))
        out[name] = spread(times)
    return out


def obstacles_ready(runs: int):
    """Obstacles ready for a Plan in Blender (``scene.KEPT``, as Plan and Bake get them,
    objects beyond the arm's reach left out by the pipeline's :func:`reach_bounds`), with
    the demo character and its workplace: one mesh object of 1M triangles in front of the
    chest (all of it within reach), then 300 set-dressing objects of 3,200 triangles each
    (960k) scattered over a 6 m cube about the character; the first build (gathered and
    built, nothing kept) and ready again (nothing changed: the signature read and
    compared, the BVH kept)."""
    from mathutils import Matrix

    from reach_addon.blender import pipeline, rig
    from reach_addon.blender.scene import KEPT, character_objects
    from reach_addon.demo import build_scene

    def measure(label, armature):
        bpy.context.view_layer.update()
        info = rig.build(armature, "right")
        within = pipeline.reach_bounds(info.arm, Settings(), [])
        exclude = character_objects(armature, bpy.context.scene)
        first, again, built = [], [], None
        for _ in range(runs):
            KEPT.clear()
            t0 = time.perf_counter()
            _p, obs, built = KEPT.get(bpy.context, exclude, within=within)
            first.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            _p, obs, rebuilt = KEPT.get(bpy.context, exclude, within=within)
            again.append(time.perf_counter() - t0)
            if not built or rebuilt:
                raise RuntimeError(f"obstacles ready: {label}: built {built}, again {rebuilt}")
        every = len([o for o in bpy.context.scene.objects
                     if o.type == "MESH" and o.name not in exclude])
        row = {"triangles": obs.triangle_count, "objects": len(obs.owner_names),
               "objects_in_scene": every,
               "first_build_ms": 1000 * statistics.median(first),
               "first_build_spread_ms": spread([1000 * t for t in first]),
               "ready_again_ms": 1000 * statistics.median(again),
               "ready_again_spread_ms": spread([1000 * t for t in again])}
        log(f"  {label}: {row['triangles']:,d} triangles of {row['objects']} of {every} "
            f"objects within reach: first build {row['first_build_ms']:.0f} ms, ready "
            f"again {row['ready_again_ms']:.1f} ms")
        return row

    armature = build_scene()
    chest = np.array(rig.build(armature, "right").joints_world["shoulder"])
    turn = np.eye(4)
    turn[:3, :3] = np.array(Matrix.Rotation(0.3, 3, "Z") @ Matrix.Rotation(0.2, 3, "X"))
    turn[:3, 3] = chest + (0.0, -0.5, -0.2)
    scan = _grid_object("Scan", 707, turn)
    one = measure("one mesh object", armature)
    one["blender_build_ms"] = blender_builds(scan, runs)
    log("  Blender's own BVH build of it: " + ", ".join(
        f"{k} {v['median']:.0f} ms" for k, v in one["blender_build_ms"].items()))
    armature = build_scene()
    rng = np.random.default_rng(0)
    base = None
    for k in range(300):
        m = np.eye(4)
        m[:3, 3] = np.array(armature.matrix_world.translation) + rng.uniform(-3.0, 3.0, 3)
        ob = _grid_object(f"Prop {k}", 40, m, None if base is None else
                          base if k % 2 else base.copy())
        base = ob.data
    many = measure("300 objects", armature)
    bpy.ops.wm.read_homefile(use_empty=True)
    return {"obstacles_ready": {"one_object": one, "many_objects": many}}


def gui_latency(runs: int):
    """Plan's wall time in Blender 3.4.1's interface (Xvfb) against headless, on the GUI
    test's plate scene (:mod:`bench.gui_latency`; at least 3 rounds)."""
    from bench import gui_latency as latency

    return latency.bench_step(max(runs, 3), log=log)


# --- 5. batch throughput ---------------------------------------------------------------------------

STUDY = """
name = "bench-throughput"
arm = "right"
[[scenes]]
file = "workplace.blend"
armature = "{armature}"
[scenes.grid]
frame = "shoulder"
min = [0.35, -0.3, -0.4]
max = [0.85, 0.5, 0.4]
count = [5, 5, 8]
"""


def batch_throughput():
    """The batch study :data:`STUDY` (200 tasks) on 1 and on 2 worker processes, run in the
    order 1, 2, 2, 1 (a machine that speeds up or slows down during the step weighs on
    both sides alike), each run into its own folder (a re-run would skip finished tasks).
    Beside the walls, the work: the tasks' own wall times summed per run
    (``batch_work_s``). Runs with the same number of processes should agree (well apart,
    the machine's speed changed during the step); two processes at once each take longer
    per task than one alone (the cores' shared cache and memory, the machine's other
    load), which is what keeps the speed-up below 2. ``bench/readme.py`` shows both."""
    from reach_addon.demo import build_scene

    folder = Path(tempfile.mkdtemp(prefix="reach-bench-"))
    armature = build_scene()
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / "workplace.blend"))
    (folder / "study.toml").write_text(STUDY.format(armature=armature.name))
    walls, work, first = {1: [], 2: []}, {1: [], 2: []}, None
    for run, workers in enumerate((1, 2, 2, 1)):
        out = folder / f"run{run}-w{workers}"
        t0 = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", "reach_addon", "batch", str(folder / "study.toml"),
             "--workers", str(workers), "--output", str(out)],
            env=dict(os.environ, PYTHONPATH=str(ROOT)), cwd=ROOT, timeout=3600,
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, check=False)
        wall = time.perf_counter() - t0
        # exit 1 means some targets were not reached, which a study may hold; anything
        # else, or a summary short of tasks, is a broken run and not a figure
        summary_path = out / "summary.json"
        if proc.returncode not in (0, 1) or not summary_path.exists():
            raise RuntimeError(f"batch on {workers} worker(s) failed (exit {proc.returncode}): "
                               f"{proc.stderr[-2000:]}")
        summary = json.loads(summary_path.read_text())
        tasks = [json.loads(f.read_text()) for f in (out / "tasks").glob("*.json")]
        if len(tasks) != summary["tasks"]:
            raise RuntimeError(f"batch on {workers} worker(s): {len(tasks)} task results for "
                               f"{summary['tasks']} tasks")
        walls[workers].append(wall)
        work[workers].append(sum(t["wall_time_s"] for t in tasks))
        log(f"  {summary['tasks']} tasks on {workers} process(es): {wall:.1f} s, "
            f"{summary['succeeded']} reached; the tasks' own time {work[workers][-1]:.1f} s")
        first = first or summary
        if (summary["tasks"], summary["succeeded"]) != (first["tasks"], first["succeeded"]):
            raise RuntimeError(f"batch: runs disagree ({first['succeeded']}/{first['tasks']} "
                               f"against {summary['succeeded']}/{summary['tasks']})")
    one, two = float(np.mean(walls[1])), float(np.mean(walls[2]))
    return {"batch_tasks": first["tasks"], "batch_reached": first["succeeded"],
            "batch_1proc_s": one, "batch_2proc_s": two, "batch_speedup_2proc": one / two,
            "batch_runs_s": {"1": walls[1], "2": walls[2]},
            "batch_work_s": {"1": work[1], "2": work[2]}}


# --- 6. tight scenes ---------------------------------------------------------------------------------

def tight_scenes(folder: Path):
    try:
        import ompl  # noqa: F401
    except ImportError as exc:
        log(f"  tight scenes skipped: {exc} (pip install -r requirements-bench.txt)")
        return {}
    from bench import tight

    return {"tight": tight.bench_step(folder, log=log)}


# --- report ------------------------------------------------------------------------------------------

def envelope(runs: int):
    """The reach envelope (:mod:`reach_addon.core.envelope`) of the standard figure's right
    arm in the demo workplace on the default grid (13 points a side, 2,197 points), from a
    fresh planner each run: the time the panel's Compute spends classifying."""
    from reach_addon.core import envelope as env_mod
    from reach_addon.core.steps import drain

    arm, settings = standard_arm(), Settings()
    points = env_mod.shoulder_frame_to_canonical(
        arm, env_mod.grid_coordinates(settings.envelope_resolution, settings.envelope_extent))
    times, env = [], None
    for _ in range(runs):
        planner = Planner(arm, obstacles(WORKPLACE), env_mod.exhaustive(settings))
        t0 = time.perf_counter()
        env = drain(env_mod.envelope_steps(planner.generator, points))
        times.append(time.perf_counter() - t0)
    ms = 1000 * statistics.median(times)
    log(f"  {len(points)} points: {ms:.0f} ms; " +
        ", ".join(f"{n} {c}" for c, n in env.counts().items()))
    return {"envelope": {"points": len(points), "time_ms": ms,
                         "spread_ms": spread([1000 * t for t in times]),
                         "counts": env.counts()}}


def everyday(runs: int):
    """Search efficiency on everyday reaches (:func:`reach_addon.samples.everyday_scenes`:
    past a plate across the straight line, round a monitor to its back, into a pulled-out
    drawer, onto a shelf above a desk; each built round the standard figure in its own
    body frame and sized by its arm), from the hanging arm, each from a fresh planner
    ``runs`` times: nodes searched against nodes in the path (the goal: at most 3×), the
    method that found the path, search and whole-plan times, and the tight bench's
    independent check of the baked frames (arm and hand)."""
    from reach_addon.core.sampling import pose_row
    from reach_addon.samples import HANGING, everyday_scenes
    from verification.race import JointSpace, path_contacts

    arm, settings = standard_arm(), Settings()
    rows = []
    for name, (verts, tris, owners, names, target) in everyday_scenes(arm).items():
        obs = Obstacles.from_triangles(verts, tris, owners, names)
        task = Task("reach", np.asarray(target)[None], HANGING)
        samples = []
        for _ in range(runs):
            planner = Planner(arm, obs, settings)
            t0 = time.perf_counter()
            plan = planner.plan(task)
            samples.append((plan, time.perf_counter() - t0))
        plan = samples[0][0]
        st = plan.stats
        m = path_contacts(JointSpace(arm, settings), verts[tris],
                          np.array([pose_row(p) for p in plan.poses]), True)
        search = [p.stats.search_time_s for p, _t in samples]
        whole = [t for _p, t in samples]
        row = {"scene": name, "success": bool(plan.success), "reason": plan.reason,
               "method": plan.segments[0].method if plan.success else None,
               "nodes_searched": st.nodes_searched, "nodes_in_solution": st.nodes_in_solution,
               "ratio": st.nodes_searched / max(st.nodes_in_solution, 1),
               "guiding_nodes": len(plan.segments[0].guiding_nodes),
               "search_time_ms": 1000 * statistics.median(search),
               "search_time_spread_ms": spread([1000 * t for t in search]),
               "plan_time_ms": 1000 * statistics.median(whole),
               "plan_time_spread_ms": spread([1000 * t for t in whole]),
               "collisions": m["collisions"], "min_clearance_arm_lengths": m["min_clearance"],
               "deterministic": len({(p.stats.nodes_searched, len(p.poses))
                                     for p, _t in samples}) == 1}
        rows.append(row)
        log(f"  {name}: {'reached' if row['success'] else row['reason']} by {row['method']}, "
            f"{row['nodes_searched']} nodes for a {row['nodes_in_solution']}-node path "
            f"({row['ratio']:.2f}×), search {row['search_time_ms']:.0f} ms, plan "
            f"{row['plan_time_ms']:.0f} ms, {row['collisions']} collisions")
    return {"everyday": rows}


def markdown(results) -> str:
    m = results["machine"]
    lines = ["# Reach benchmark", "",
             f"Reach {results['reach_version']} on Blender {results['blender_version']} (bpy), "
             f"{m['cpu']}, {m['cores']} cores, Python {m['python']}; {results['runs']} runs, "
             f"medians (min–max); {results['date']}.", "",
             "## Table 2 (the demo workplace, the core's standard figure)", "",
             "| task | search ms (spread) | paper ms | speed-up | prep ms | nodes | paper | "
             "in solution | paper | length (arm lengths) | paper | µs/node |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results.get("table2", []):
        sp = r["search_time_spread_s"]
        lines.append(
            f"| {r['task']} | {1000 * r['search_time_s']:.1f} ({1000 * sp['min']:.1f}–"
            f"{1000 * sp['max']:.1f}) | {1000 * r['paper_search_time_s']:.0f} | "
            f"{r['speedup_vs_paper']:.0f}× | {1000 * r['preprocess_time_s']:.0f} | "
            f"{r['nodes_searched']} | {r['paper_nodes_searched']} | {r['nodes_in_solution']} | "
            f"{r['paper_nodes_in_solution']} | {r['path_length_arm_lengths']:.2f} | "
            f"{r['paper_path_length_arm_lengths']:.2f} | {1000 * r['time_per_node_ms']:.0f} |")
    if results.get("everyday"):
        lines += ["", "## Everyday reaches (search efficiency; the standard figure from the "
                  "hanging arm)", "",
                  "| scene | result | method | nodes searched | in path | ratio (goal ≤ 3×) | "
                  "guiding nodes | search ms (spread) | plan ms (spread) | collisions "
                  "(independent) |", "|---|---|---|---|---|---|---|---|---|---|"]
        for e in results["everyday"]:
            ss, ps = e["search_time_spread_ms"], e["plan_time_spread_ms"]
            lines.append(
                f"| {e['scene']} | {'reached' if e['success'] else e['reason']} | "
                f"{e['method'] or '–'} | {e['nodes_searched']} | {e['nodes_in_solution']} | "
                f"{e['ratio']:.2f} | {e['guiding_nodes']} | {e['search_time_ms']:.0f} "
                f"({ss['min']:.0f}–{ss['max']:.0f}) | {e['plan_time_ms']:.0f} "
                f"({ps['min']:.0f}–{ps['max']:.0f}) | {e['collisions']} |")
    if results.get("table1"):
        t = results["table1"]
        lines += ["", "## Table 1 on baked reaches (the demo character; `bench/table1.png`)", "",
                  "| row | directions | reached | chest at arrival − Table 1, ° (min … max) |",
                  "|---|---|---|---|"]
        for row in sorted({p["row_m"] for p in t["points"]}):
            mine = [p for p in t["points"] if p["row_m"] == row]
            errors = [p["error_deg"] for p in mine if p["success"]]
            lines.append(f"| {100 * row:.0f} cm | {mine[0]['direction_deg']:.0f}–"
                         f"{mine[-1]['direction_deg']:.0f}° | {len(errors)}/{len(mine)} | "
                         + (f"{min(errors):+.2f} … {max(errors):+.2f} |" if errors else "– |"))
    lines += ["", "## The hand (same plans)", "",
              "| task | plan ms (spread) | frames | wrist turn °/frame (max) | hand turn °/frame "
              "in space (max) | wrist bend ° mean / max | frames added | over the bound | "
              "touching between keys |", "|---|---|---|---|---|---|---|---|---|"]
    for r in results.get("table2", []):
        if "max_wrist_turn_deg_per_frame" not in r:
            continue
        sp = r["planning_time_spread_s"]
        lines.append(
            f"| {r['task']} | {1000 * r['planning_time_s']:.0f} ({1000 * sp['min']:.0f}–"
            f"{1000 * sp['max']:.0f}) | {r['frames']} | {r['max_wrist_turn_deg_per_frame']:.1f} | "
            f"{r['max_hand_turn_deg_per_frame']:.1f} | {r['mean_wrist_bend_deg']:.1f} / "
            f"{r['max_wrist_bend_deg']:.1f} | {r['inserted_frames']} | "
            f"{r['unbounded_hand_turns']} | {r['touching_transitions']} |")
    lines += ["", "Wrist turn: the hand relative to the forearm, bounded by the hand turn speed "
              "limit (15° a frame at 24 fps); in space it adds the forearm's own turn. Touching: "
              "transitions whose interpolated instants (4 a frame) touch an obstacle by the "
              "planner's own check at half the clearance; the race below counts the same by an "
              "independent check."]
    if results["ompl"]:
        lines += ["", "## Against OMPL RRTConnect (+ simplification)", "",
                  "| task | runs | Reach ms (spread) | OMPL ms (spread) | OMPL / Reach | "
                  "passed Reach / OMPL | Reach length | OMPL length | Reach f_R | OMPL f_R | "
                  "Reach collisions | OMPL collisions | Reach nodes, BVH queries | "
                  "OMPL states, BVH queries |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]

        def _ms_spread(r, key):
            sp = r.get(key + "_spread")
            return f"{1000 * r[key]:.1f}" + (
                f" ({1000 * sp['min']:.0f}–{1000 * sp['max']:.0f})" if sp else "")

        for r in results["ompl"]:
            ratio = r.get("time_ratio_ompl_over_reach")
            lines.append(
                f"| {r['task']} | {r.get('runs', '')} | {_ms_spread(r, 'reach_time_s')} | "
                f"{_ms_spread(r, 'ompl_time_s')} | {'–' if ratio is None else f'{ratio:.2f}'} | "
                f"{r.get('reach_passed', '')} / {r.get('ompl_passed', '')} | "
                f"{r['reach_path_length']:.2f} | {r['ompl_path_length']:.2f} | "
                f"{r['reach_mean_f_r']:.2f} | {r['ompl_mean_f_r']:.2f} | "
                f"{r['reach_collisions']:g} ({r['reach_arm_collisions']:g}) | "
                f"{r['ompl_collisions']:g} ({r['ompl_arm_collisions']:g}) | "
                f"{r.get('reach_nodes_searched', '')}, {r.get('reach_obstacle_queries', '')} | "
                f"{r.get('ompl_validity_checks', 0):.0f}, {r.get('ompl_obstacle_queries', '')} |")
        lines += ["", "Reach's time is its whole plan on a fresh planner, the workspace grid "
                  "included where the task builds it; OMPL's runs from its goal region (the same "
                  "IK's legal, clear poses at the target) to the simplified path, its set-up "
                  "before the clock. OMPL / Reach: ratio of the median times over the runs where "
                  "both paths pass the independent check. Collisions: densely interpolated poses "
                  "between keys that touch an obstacle by an independent check (capsules of the "
                  "arm and of the hand to its far end, exact distances), (n) of them with the "
                  "arm, the rest with the hand alone. BVH queries: counted the same way for both "
                  "on an untimed re-run of seed 0."]
    if results.get("tight"):
        from bench import tight

        lines += ["", tight.markdown(results["tight"]).rstrip("\n")]
    lines += ["", "## Other figures", ""]
    for k in ("chase_update_ms_p50", "chase_update_ms_p95",
              "bake_1000_frames_ms", "bake_bones", "gather_10k_instances_ms",
              "gather_10k_instances_triangles", "batch_tasks", "batch_reached",
              "batch_1proc_s", "batch_2proc_s", "batch_speedup_2proc"):
        if k in results:
            v = results[k]
            lines.append(f"- `{k}`: {v:.2f}" if isinstance(v, float) else f"- `{k}`: {v}")
    if results.get("envelope"):
        e = results["envelope"]
        lines.append(f"- reach envelope, {e['points']:,} points: {e['time_ms']:.0f} ms "
                     f"({e['spread_ms']['min']:.0f}–{e['spread_ms']['max']:.0f}); " +
                     ", ".join(f"{n} {c}" for c, n in e["counts"].items()))
    for label, r in (results.get("obstacles_ready") or {}).items():
        lines.append(f"- obstacles ready ({label.replace('_', ' ')}, {r['triangles']:,} "
                     f"triangles): first build {r['first_build_ms']:.0f} ms "
                     f"({r['first_build_spread_ms']['min']:.0f}–"
                     f"{r['first_build_spread_ms']['max']:.0f}), ready again "
                     f"{r['ready_again_ms']:.1f} ms ({r['ready_again_spread_ms']['min']:.1f}–"
                     f"{r['ready_again_spread_ms']['max']:.1f})")
    for name, r in ((k, v) for k, v in (results.get("gui_latency") or {}).items()
                    if isinstance(v, dict)):
        lines.append(f"- Plan in Blender {results['gui_latency']['blender']}'s interface "
                     f"({name} settings, {r['nodes_searched']} nodes): wall "
                     f"{1000 * r['gui_wall_s']['median']:.0f} ms (result drawn "
                     f"{1000 * r['gui_shown_s']['median']:.0f} ms), headless "
                     f"{1000 * r['headless_wall_s']['median']:.0f} ms, planner "
                     f"{1000 * r['gui_planner_s']['median']:.0f} / "
                     f"{1000 * r['headless_planner_s']['median']:.0f} ms; interface / headless "
                     f"{r['ratio']['median']:.2f}× ({r['ratio']['min']:.2f}–{r['ratio']['max']:.2f})"
                     f", {r['redraws_per_s']['median']:.1f} progress redraws a second")
    if results.get("scaling"):
        lines += ["", "| triangles | search ms | BVH build ms |", "|---|---|---|"]
        for r in results["scaling"]:
            lines.append(f"| {r['triangles']:,} | {1000 * r['search_time_s']:.1f} | "
                         f"{1000 * r['bvh_build_time_s']:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--skip", action="append", default=[],
                        choices=("table2", "table1", "ompl", "chase", "bake", "scaling",
                                 "gather", "ready", "batch", "tight", "envelope", "everyday",
                                 "gui_latency"))
    parser.add_argument("--output", default=str(ROOT / "bench"))
    args = parser.parse_args(argv)
    results = {"reach_version": __version__, "blender_version": bpy.app.version_string,
               "runs": args.runs, "date": time.strftime("%Y-%m-%d %H:%M"),
               "machine": {"cpu": platform.processor() or platform.machine(),
                           "cores": os.cpu_count(), "python": platform.python_version(),
                           "system": platform.platform()}}
    steps = [("table2", "Table 2", lambda: {"table2": table2(args.runs)}),
             ("table1", "Table 1 on baked reaches (bench/table1.png)", table1),
             ("ompl", "OMPL race", lambda: {"ompl": ompl(args.runs)}),
             ("chase", "chase / live re-plan", chase_updates),
             ("envelope", "reach envelope", lambda: envelope(args.runs)),
             ("everyday", "everyday reaches (search efficiency)", lambda: everyday(args.runs)),
             ("bake", "bake", lambda: bake_1000(args.runs)),
             ("scaling", "obstacle scaling", lambda: {"scaling": scaling(args.runs)}),
             ("gather", "obstacles from a 10,000-instance scatter",
              lambda: gather_scatter(args.runs)),
             ("ready", "obstacles ready in Blender: first build and kept",
              lambda: obstacles_ready(args.runs)),
             ("gui_latency", "Plan in Blender 3.4.1's interface against headless "
              "(bench/gui_latency.py)", lambda: gui_latency(args.runs)),
             ("batch", "batch throughput", batch_throughput),
             ("tight", "tight scenes against OMPL (bench/tight.json)",
              lambda: tight_scenes(Path(args.output)))]
    results.setdefault("ompl", [])
    for key, title, fn in steps:
        if key == "tight" and key in args.skip:
            # the tight scenes take most of an hour: a skipped step keeps the summary of the
            # last full run (bench/tight.json names the commit it ran on)
            saved = Path(args.output) / "tight.json"
            if saved.exists():
                tight_run = json.loads(saved.read_text())
                results["tight"] = {k: tight_run[k] for k in (
                    "count", "seed", "ompl_time_s", "arms", "summary", "wall_time_s",
                    "reach_commit") if k in tight_run}
                log(f"tight scenes: kept from {saved} (Reach at "
                    f"{tight_run.get('reach_commit', '?')})")
            continue
        if key in args.skip:
            continue
        log(f"{title}:")
        results.update(fn())
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(results, indent=2))
    (out / "results.md").write_text(markdown(results))
    log(f"wrote {out / 'results.json'} and {out / 'results.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
