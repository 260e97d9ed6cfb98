"""Reach against OMPL's RRTConnect on the paper's four tasks: the race's table.

``python -m bench.ompl_race [--seed N] [--time-limit S] [--task NAME ...]`` races the four
demo tasks (:func:`reach_addon.demo.demo_tasks` in :data:`reach_addon.demo.WORKPLACE`) once
each with :func:`verification.race.race` and prints one row a task: both planners' times
(seconds), wrist path lengths (arm lengths), mean f_R and contacts by the independent
check, then the work each did (nodes, BVH queries, states checked). ``make bench`` races
them with many seeds (``bench/run.py``). The harness and why it is fair:
:mod:`verification.race`, ``docs/design.md``.
"""

from __future__ import annotations

import argparse
import sys

from reach_addon.core import Planner
from verification.race import DENSE_SPACING, race


# --- command line --------------------------------------------------------------------------

def _ratio(x) -> str:
    return "–" if x is None else f"{x:.2f}"


def _hits(total: int, arm: int) -> str:
    return f"{total} ({arm})"


def format_table(rows) -> str:
    """The race results as a text table, with notes."""
    head = (f"{'task':15s} {'legs':>4s} {'Reach s':>8s} {'OMPL s':>8s} {'×':>6s} "
            f"{'Reach len':>9s} {'OMPL len':>8s} {'Reach f_R':>9s} {'OMPL f_R':>8s} "
            f"{'Reach hits':>10s} {'OMPL hits':>9s}")
    lines = [head, "-" * len(head)]
    for r in rows:
        flag = "" if r["reach_success"] and r["ompl_success"] else (
            "  (" + ", ".join(k for k, ok in (("Reach failed", r["reach_success"]),
                                              ("OMPL failed", r["ompl_success"])) if not ok) + ")")
        lines.append(
            f"{r['task']:15s} {r['legs']:4d} {r['reach_time_s']:8.3f} {r['ompl_time_s']:8.3f} "
            f"{_ratio(r['time_ratio']):>6s} {r['reach_path_length']:9.2f} {r['ompl_path_length']:8.2f} "
            f"{r['reach_mean_f_r']:9.2f} {r['ompl_mean_f_r']:8.2f} "
            f"{_hits(r['reach_collisions'], r['reach_arm_collisions']):>10s} "
            f"{_hits(r['ompl_collisions'], r['ompl_arm_collisions']):>9s}{flag}")
    lines.append("")
    lines.append("times in seconds (× = OMPL / Reach); lengths: wrist path in arm lengths; f_R: "
                 "mean strength category along the path (0 strongest, 2 weakest); hits: densely "
                 f"interpolated poses ({DENSE_SPACING} arm lengths of wrist travel apart) that "
                 "touch an obstacle by the independent check, (n) of them with the arm, the "
                 "rest with the hand alone")
    lines += [f"note: {r['note']}" for r in rows if r["note"]]
    return "\n".join(lines)


def main(argv=None) -> int:
    """Race the four demo tasks and print the table."""
    parser = argparse.ArgumentParser(prog="python -m bench.ompl_race", description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=0, help="OMPL's random seed (default 0)")
    parser.add_argument("--time-limit", type=float, default=10.0,
                        help="seconds OMPL may spend on one leg (default 10)")
    parser.add_argument("--task", action="append", default=None,
                        help="race only this task (repeatable): collision_free, rotation, "
                             "guided, chase")
    args = parser.parse_args(argv)

    import bpy  # noqa: F401  (mathutils and its BVH tree, for the core's obstacles)

    from reach_addon.core import Settings
    from reach_addon.demo import WORKPLACE, demo_tasks
    from reach_addon.samples import obstacles, standard_arm

    tasks = [(n, t) for n, t in demo_tasks() if args.task is None or n in args.task]
    if not tasks:
        print(f"no task named {', '.join(args.task)}; choose from collision_free, rotation, "
              "guided, chase", file=sys.stderr)
        return 2
    rows = [race(name, Planner(standard_arm(), obstacles(WORKPLACE), Settings()), task,
                 seed=args.seed, time_limit_s=args.time_limit, count_queries=True)
            for name, task in tasks]
    print(format_table(rows))
    print("\nwork: " + "; ".join(
        f"{r['task']} Reach {r['reach_nodes_searched']} nodes, "
        f"{r['reach_obstacle_queries']} BVH queries (grid {1000 * r['reach_preprocess_time_s']:.0f}"
        f" ms in its time) / OMPL {r['ompl_validity_checks']} states checked, "
        f"{r['ompl_obstacle_queries']} BVH queries" for r in rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
