"""Two revisions of Reach on one clock: the Table 2 tasks and the everyday reaches, timed
side by side (a benchmark: it measures and asserts nothing).

    python bench/compare.py --base 735c599 [--head HEAD] [--rounds 8] [--reps 3] [--warm]

Each revision is checked out in a temporary git worktree (``--head`` ``WORKTREE`` times
the working tree as it is). Every round starts one fresh Python process per revision; the
order alternates (A B, B A, ...) so that a machine growing busier or quieter weighs on
both alike. In its process each task is planned ``--reps`` times, each from a fresh
planner, on the same problem (the standard figure in the demo workplace; the everyday
scenes of :func:`reach_addon.samples.everyday_scenes`), and the process reports the
median of its repetitions; with ``--warm`` the process first plans every task once,
untimed, as a long-lived Blender session has (without it the first tasks also pay what a
fresh process fills once: a one-shot CLI bake). Per task: the median over rounds of those medians, for the
search alone and for the whole plan (search, smoothing, timing, the hand pass); the best
(least) of all the runs, which a busy machine disturbs least; and the ratio head / base of
each round's pair (run next to each other), its median per task and the geometric mean of
those over the tasks. And a count no clock disturbs: the Python function calls of one
whole plan (:mod:`cProfile`), the interpreter's work. With the nodes searched and a digest
of the poses, so that a difference in work is not taken for one in speed.

Writes ``bench/compare.json``; ``bench/readme.py`` reads it for the README.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# Runs inside the revision's own tree: only names both sides of a comparison have.
CHILD = r"""
import cProfile, hashlib, json, pstats, statistics, sys, time
sys.path.insert(0, sys.argv[1])
import bpy  # noqa: F401  (mathutils and the BVH come with the wheel)
import numpy as np
from reach_addon.core import Planner, Settings, Task
from reach_addon.core.collision import Obstacles
from reach_addon.core.sampling import pose_row
from reach_addon.demo import WORKPLACE, demo_tasks
from reach_addon.samples import HANGING, everyday_scenes, obstacles, standard_arm

reps, warm = int(sys.argv[2]), sys.argv[3] == "warm"
arm, settings = standard_arm(), Settings()
problems = [(name, obstacles(WORKPLACE), task) for name, task in demo_tasks()]
for name, (verts, tris, owners, names, target) in everyday_scenes(arm).items():
    problems.append((name, Obstacles.from_triangles(verts, tris, owners, names),
                     Task("reach", np.asarray(target)[None], HANGING)))
if warm:                                # every task once, untimed
    for name, obs, task in problems:
        Planner(arm, obs, settings).plan(task)
out = {}
for name, obs, task in problems:
    search, whole = [], []
    for _ in range(reps):
        planner = Planner(arm, obs, settings)
        planner.workspace
        t0 = time.perf_counter()
        plan = planner.plan(task)
        whole.append(time.perf_counter() - t0)
        search.append(plan.stats.search_time_s)
    profile = cProfile.Profile()        # the interpreter's work, which no clock disturbs
    planner = Planner(arm, obs, settings)
    planner.workspace
    profile.enable()
    planner.plan(task)
    profile.disable()
    calls = pstats.Stats(profile).total_calls
    poses = np.array([pose_row(p) for p in plan.poses], float)
    out[name] = {"search_s": statistics.median(search), "plan_s": statistics.median(whole),
                 "search_min_s": min(search), "plan_min_s": min(whole), "calls": calls,
                 "nodes": plan.stats.nodes_searched, "success": bool(plan.success),
                 "poses": hashlib.sha256(np.round(poses, 9).tobytes()).hexdigest()[:16]}
print("RESULT " + json.dumps(out))
"""


def _git(*args, cwd=ROOT) -> str:
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True,
                          text=True).stdout.strip()


def _run(tree: Path, reps: int, warm: bool) -> dict:
    done = subprocess.run([sys.executable, "-c", CHILD, str(tree), str(reps),
                           "warm" if warm else "cold"],
                          capture_output=True, text=True, cwd=tree)
    for line in done.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(f"the timing run in {tree} failed:\n{done.stderr[-2000:]}")


def compare(base: str, head: str, rounds: int, reps: int, warm: bool = False) -> dict:
    with tempfile.TemporaryDirectory(prefix="reach-compare-") as tmp:
        trees, revs = {}, {}
        for side, rev in (("base", base), ("head", head)):
            if rev == "WORKTREE":
                trees[side], revs[side] = ROOT, _git("rev-parse", "--short", "HEAD") + "+"
                continue
            revs[side] = _git("rev-parse", "--short", rev)
            trees[side] = Path(tmp) / side
            _git("worktree", "add", "--detach", str(trees[side]), revs[side])
        try:
            samples = {"base": [], "head": []}
            for r in range(rounds):
                order = ("base", "head") if r % 2 == 0 else ("head", "base")
                for side in order:
                    samples[side].append(_run(trees[side], reps, warm))
                print(f"round {r + 1}/{rounds} done", flush=True)
        finally:
            for tree in trees.values():
                if tree != ROOT:
                    _git("worktree", "remove", "--force", str(tree))
    rows = []
    for name in samples["base"][0]:
        row = {"task": name}
        for side in ("base", "head"):
            s = samples[side]
            row[side] = {
                "search_ms": 1000 * statistics.median(x[name]["search_s"] for x in s),
                "plan_ms": 1000 * statistics.median(x[name]["plan_s"] for x in s),
                "search_ms_best": 1000 * min(x[name]["search_min_s"] for x in s),
                "plan_ms_best": 1000 * min(x[name]["plan_min_s"] for x in s),
                "plan_ms_max": 1000 * max(x[name]["plan_s"] for x in s),
                "nodes": s[0][name]["nodes"], "success": s[0][name]["success"],
                "calls": s[0][name]["calls"],
                "poses": s[0][name]["poses"]}
        # each round's head over base, the two run next to each other: a paired ratio
        paired = sorted(h[name]["plan_s"] / b[name]["plan_s"]
                        for b, h in zip(samples["base"], samples["head"]))
        row["paired_ratio"] = statistics.median(paired)
        row["paired_ratio_quartiles"] = [float(q) for q in
                                         statistics.quantiles(paired, n=4)[::2]]
        row["calls_ratio"] = row["head"]["calls"] / row["base"]["calls"]
        row["same_plan"] = (row["base"]["poses"] == row["head"]["poses"]
                            and row["base"]["nodes"] == row["head"]["nodes"])
        row["search_ratio"] = row["head"]["search_ms"] / max(row["base"]["search_ms"], 1e-9)
        row["plan_ratio"] = row["head"]["plan_ms"] / max(row["base"]["plan_ms"], 1e-9)
        row["best_plan_ratio"] = row["head"]["plan_ms_best"] / max(row["base"]["plan_ms_best"],
                                                                   1e-9)
        rows.append(row)
    logs = [math.log(r["paired_ratio"]) for r in rows]
    return {"base": revs["base"], "head": revs["head"], "rounds": rounds, "reps": reps,
            "warm": warm,
            "geometric_mean_paired_ratio": math.exp(sum(logs) / len(logs)),
            "geometric_mean_calls_ratio": math.exp(sum(math.log(r["calls_ratio"])
                                                       for r in rows) / len(rows)),
            "date": datetime.date.today().isoformat(),
            "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}",
            "rows": rows}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", required=True, help="the earlier revision")
    parser.add_argument("--head", default="HEAD", help="a revision, or WORKTREE")
    parser.add_argument("--rounds", type=int, default=8)
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--warm", action="store_true",
                        help="plan every task once, untimed, before timing (a long-lived "
                             "Blender session) instead of from a fresh process (one CLI bake)")
    parser.add_argument("--output", default=str(ROOT / "bench" / "compare.json"))
    args = parser.parse_args(argv)
    result = compare(args.base, args.head, args.rounds, args.reps, args.warm)
    print(f"{'task':16s} {'search ms':>19s} {'whole plan ms (median)':>24s} "
          f"{'whole plan ms (best)':>24s} paired  calls  same plan")
    for r in result["rows"]:
        b, h = r["base"], r["head"]
        print(f"{r['task']:16s} {b['search_ms']:7.1f} → {h['search_ms']:7.1f} "
              f"({r['search_ratio']:.2f}×) {b['plan_ms']:8.1f} → {h['plan_ms']:8.1f} "
              f"({r['plan_ratio']:.2f}×) {b['plan_ms_best']:8.1f} → {h['plan_ms_best']:8.1f} "
              f"({r['best_plan_ratio']:.2f}×) {r['paired_ratio']:.2f}× {r['calls_ratio']:.3f}×  "
              f"{'yes' if r['same_plan'] else 'NO'}")
    print(f"whole plan, head over base, paired by round, geometric mean over the tasks: "
          f"{result['geometric_mean_paired_ratio']:.3f}×; Python calls "
          f"{result['geometric_mean_calls_ratio']:.3f}×")
    Path(args.output).write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
