"""Tight scenes (issue 14): does Reach find a path wherever one exists?

``python bench/tight.py [--quick] [--count N] [--seed S] [--ompl-time S] [--arm A]
[--family F] [--no-rigs] [--ompl-from JSON] [--table JSON]`` generates ``--count`` tight
scenes (:func:`verification.tight.scene_plan`, :func:`verification.tight.generate`) and
plans each (:func:`verification.tight.plan_scene`): OMPL's RRTConnect with ``--ompl-time``
CPU seconds decides whether a path exists, then Reach plans it. It writes
``bench/tight.json`` (one record per scene, after each) and prints a markdown table (per
family and arm, per family, per arm, in total) against the goal: Reach succeeds on at least
:data:`GOAL_RATE` of the scenes OMPL solves, its median time well under OMPL's. ``make
bench`` runs it as its step ``tight`` (:func:`bench_step`); ``--quick``: 20 scenes, 5 s for
OMPL.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from reach_addon.core import Settings  # noqa: E402
from reach_addon.core.arm import ArmConfig, ArmModel  # noqa: E402
from verification.tight import (ARMS, FAMILIES, SYNTHETIC_ARMS, generate,  # noqa: E402
                                limb_radius, make_arm, plan_scene, scene_plan, start_config)

#: Scenes, OMPL's seconds per scene: the full run and ``--quick``.
DEFAULT_COUNT, DEFAULT_OMPL_TIME = 240, 20.0
QUICK_COUNT, QUICK_OMPL_TIME = 20, 5.0
GOAL_RATE = 0.99


# --- the run and its table -----------------------------------------------------------------

def run(count: int = DEFAULT_COUNT, seed: int = 0, ompl_time_s: float = DEFAULT_OMPL_TIME,
        arms=ARMS, families=FAMILIES, log=print, output: Path | None = None,
        ompl_from: dict | None = None) -> dict:
    """Generate and plan ``count`` scenes; write ``output`` (JSON) after every scene if
    given. Returns {"settings": ..., "scenes": [records], "summary": ...}.

    ``ompl_from``: a finished run (its JSON) whose OMPL side is taken instead of solving
    again, scene by scene (matched by arm, family and seed, and checked to be the same
    scene: its gap and target); only Reach plans. For a change to Reach alone: OMPL's side
    does not depend on Reach's settings, and it is most of an hour of the run. The record
    says so (``ompl_from``)."""
    settings = Settings()
    arm_models = {name: make_arm(name) for name in dict.fromkeys(a for a, _f, _s in
                                                                 scene_plan(count, seed, arms,
                                                                            families))}
    starts = {name: start_config(arm, settings) for name, arm in arm_models.items()}
    result = {"count": count, "seed": seed, "ompl_time_s": ompl_time_s,
              "reach_commit": git_commit(),
              "arms": {name: arm_record(arm, starts[name]) for name, arm in arm_models.items()},
              "scenes": []}
    earlier = {}
    if ompl_from is not None:
        result["ompl_from"] = ompl_from.get("source", "an earlier run")
        result["ompl_time_s"] = ompl_from["ompl_time_s"]
        earlier = {(r["arm"], r["family"], r["seed"]): r for r in ompl_from["scenes"]}
    t_all = time.perf_counter()
    for k, (arm_name, family, scene_seed) in enumerate(scene_plan(count, seed, arms, families)):
        scene = generate(arm_name, arm_models[arm_name], family, scene_seed, settings,
                         starts[arm_name])
        old = earlier.get((arm_name, family, scene_seed))
        if ompl_from is not None:
            same = scene.record()
            if old is None or (old["target"], old["gap_width"]) != (same["target"],
                                                                    same["gap_width"]):
                raise ValueError(f"scene {arm_name}/{family}/{scene_seed} is not in the "
                                 "earlier run, or is not the same scene there")
            row = plan_scene(scene, 0.0, settings, run_ompl=False)
            row.update({key: v for key, v in old.items() if key.startswith("ompl_")})
        else:
            row = plan_scene(scene, ompl_time_s, settings)
        result["scenes"].append(row)
        log(f"  [{k + 1}/{count}] {family:5s} {arm_name:11s} seed {scene_seed}: OMPL "
            f"{'solved' if row['ompl_solved'] else 'unsolved'} {row['ompl_time_s']:.2f} s; "
            f"Reach {'ok' if row['reach_success'] else row['reach_reason']} "
            f"({row['reach_method'] or '-'}) {row['reach_time_s']:.2f} s, "
            f"{row['reach_nodes']} nodes")
        if output is not None:
            result["summary"] = summary(result["scenes"])
            write_json(output, result)
    result["wall_time_s"] = time.perf_counter() - t_all
    result["summary"] = summary(result["scenes"])
    if output is not None:
        write_json(output, result)
    return result


def git_commit() -> str:
    """The commit Reach runs at (``-dirty`` with uncommitted changes), or '?'."""
    import subprocess

    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT,
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "?"


def arm_record(arm: ArmModel, start: ArmConfig) -> dict:
    return {"name": arm.name, "arm_length": arm.arm_length,
            "lengths": [arm.upper_arm_length, arm.forearm_length, arm.hand_length],
            "radii": [arm.upper_arm_radius, arm.forearm_radius, arm.hand_radius],
            "limb_radius": limb_radius(arm), "start": start.as_array().tolist()}


def write_json(path: Path, data) -> None:
    path = Path(path)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def _median(values):
    values = list(values)
    return statistics.median(values) if values else None


def _cell(rows) -> dict:
    solved = [r for r in rows if r["ompl_solved"]]
    reached = [r for r in solved if r["reach_success"]]
    methods: dict = {}
    for r in reached:
        methods[r["reach_method"]] = methods.get(r["reach_method"], 0) + 1
    return {"scenes": len(rows), "ompl_solved": len(solved), "reach_solved": len(reached),
            "reach_rate": len(reached) / len(solved) if solved else None,
            "reach_methods": methods,
            "reach_only": sum(1 for r in rows if r["reach_success"] and not r["ompl_solved"]),
            "reach_touching": sum(1 for r in rows if r["reach_planned"] and r["reach_collisions"]),
            "reach_median_s": _median(r["reach_time_s"] for r in solved),
            "reach_median_success_s": _median(r["reach_time_s"] for r in reached),
            "reach_median_search_s": _median(r["reach_search_time_s"] for r in solved),
            # the plan with the workspace grid built for it (built before the plan's clock)
            "reach_median_with_grid_s": _median(
                r["reach_time_s"] + r.get("reach_preprocess_time_s", 0.0) for r in solved),
            "ompl_median_s": _median(r["ompl_time_s"] for r in solved),
            "reach_median_cpu_s": _median(r.get("reach_cpu_s", math.nan) for r in solved),
            "ompl_median_cpu_s": _median(r.get("ompl_cpu_s", math.nan) for r in solved)}


def summary(rows) -> dict:
    """Per family and arm, per family, per arm and in total (see :func:`markdown`)."""
    cells = []
    for family in FAMILIES:
        for arm in ARMS:
            mine = [r for r in rows if r["family"] == family and r["arm"] == arm]
            if mine:
                cells.append({"family": family, "arm": arm, **_cell(mine)})
    by_family = [{"family": f, "arm": "all", **_cell([r for r in rows if r["family"] == f])}
                 for f in FAMILIES if any(r["family"] == f for r in rows)]
    by_arm = [{"family": "all", "arm": a, **_cell([r for r in rows if r["arm"] == a])}
              for a in ARMS if any(r["arm"] == a for r in rows)]
    total = {"family": "all", "arm": "all", **_cell(rows)}
    total["goal_rate"] = GOAL_RATE
    total["goal_met"] = total["reach_rate"] is not None and total["reach_rate"] >= GOAL_RATE
    failures = [{k: r.get(k) for k in ("seed", "family", "kind", "arm", "factor",
                                       "reach_reason", "reach_nodes", "reach_sampling_states",
                                       "reach_time_s", "ompl_time_s", "reach_message")}
                for r in rows if r["ompl_solved"] and not r["reach_success"]]
    return {"cells": cells, "by_family": by_family, "by_arm": by_arm, "total": total,
            "failures": failures}


def _ms(x):
    return "–" if x is None else f"{1000 * x:.0f}"


def _row(c) -> str:
    rate = "–" if c["reach_rate"] is None else f"{100 * c['reach_rate']:.1f} %"
    methods = ", ".join(f"{m} {n}" for m, n in sorted(c["reach_methods"].items())) or "–"
    return (f"| {c['family']} | {c['arm']} | {c['scenes']} | {c['ompl_solved']} | "
            f"{c['reach_solved']} ({rate}) | {methods} | {_ms(c['reach_median_s'])} | "
            f"{_ms(c.get('reach_median_search_s'))} | {_ms(c['ompl_median_s'])} |")


def markdown(result: dict) -> str:
    """The table: per family and arm, per family, per arm, and the total against the goal."""
    s = result["summary"]
    t = s["total"]
    lines = [f"## Tight scenes (issue 14: Reach on ≥ {100 * GOAL_RATE:.0f} % of what OMPL solves)",
             "",
             f"{t['scenes']} scenes from seed {result['seed']} (`bench/tight.py`, per scene in "
             f"`bench/tight.json`); OMPL RRTConnect with {result['ompl_time_s']:g} s of CPU time per "
             "scene decides whether a path exists. Reach's column counts its successes among the "
             "scenes OMPL solved, a success touching an obstacle by the independent check "
             "counted as a failure; medians over the scenes OMPL solved, in ms: Reach's whole "
             "plan (search, smoothing, timing, the hand pass), its search alone, OMPL's "
             "`solve` (no simplification)."
             + (f" Reach at `{result['reach_commit']}`." if result.get("reach_commit") else ""),
             "",
             "| family | arm | scenes | OMPL solved | Reach solved (of those) | by method | "
             "Reach plan ms | Reach search ms | OMPL ms |", "|---|---|---|---|---|---|---|---|---|"]
    lines += [_row(c) for c in s["cells"]]
    lines += [_row(c).replace(f"| {c['family']} | all |", f"| **{c['family']}** | all |")
              for c in s["by_family"]]
    lines += [_row(c).replace(f"| all | {c['arm']} |", f"| all | **{c['arm']}** |")
              for c in s["by_arm"]]
    lines.append(_row(t).replace("| all | all |", "| **total** | |"))
    rate = t["reach_rate"]
    lines += ["", f"Goal ≥ {100 * GOAL_RATE:.0f} %: **{'met' if t['goal_met'] else 'not met'}**"
              + ("" if rate is None else f" ({100 * rate:.1f} %)")
              + (f"; Reach's median {_ms(t['reach_median_s'])} ms "
                 f"({_ms(t.get('reach_median_with_grid_s'))} ms with its workspace grid) "
                 f"against OMPL's {_ms(t['ompl_median_s'])} ms (CPU time "
                 f"{_ms(t['reach_median_cpu_s'])} against {_ms(t['ompl_median_cpu_s'])} ms)"
                 if rate is not None else "")
              + f". Reach succeeded on {t['reach_only']} scene(s) OMPL did not solve; "
              f"{t['reach_touching']} plan(s) reported as reached touched an obstacle by the "
              "independent check."]
    if s["failures"]:
        lines += ["", "Scenes OMPL solves and Reach does not (nodes: positions the best-first "
                  "search tested; states: the sampling fallback's):", "",
                  "| seed | family | arm | gap factor | Reach's reason | nodes | states | "
                  "Reach s | OMPL s | Reach's message |", "|---|---|---|---|---|---|---|---|---|---|"]
        for f in s["failures"]:
            message = (f.get("reach_message") or "").split(";")[0].replace("|", "/")
            lines.append(f"| {f['seed']} | {f['family']} ({f['kind']}) | {f['arm']} | "
                         f"{f['factor']:.2f} | {f['reach_reason']} | {f['reach_nodes']} | "
                         f"{f.get('reach_sampling_states') or '–'} | {f['reach_time_s']:.2f} | "
                         f"{f['ompl_time_s']:.2f} | {message} |")
    return "\n".join(lines) + "\n"


def bench_step(folder: Path, log=print, count: int = DEFAULT_COUNT,
               ompl_time_s: float = DEFAULT_OMPL_TIME) -> dict:
    """``make bench``'s step: the full run, ``bench/tight.json``; returns what
    ``bench/run.py`` keeps in ``results.json`` (settings and summary)."""
    folder = Path(folder)
    result = run(count, ompl_time_s=ompl_time_s, log=log, output=folder / "tight.json")
    t = result["summary"]["total"]
    rate = "–" if t["reach_rate"] is None else f"{100 * t['reach_rate']:.1f} %"
    log(f"  Reach {t['reach_solved']}/{t['ompl_solved']} of the scenes OMPL solved ({rate}); "
        f"median Reach {_ms(t['reach_median_s'])} ms, OMPL {_ms(t['ompl_median_s'])} ms")
    return {k: result[k] for k in ("count", "seed", "ompl_time_s", "arms", "summary",
                                   "wall_time_s", "reach_commit") if k in result}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=None,
                        help=f"scenes (default {DEFAULT_COUNT}; --quick {QUICK_COUNT})")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--ompl-time", type=float, default=None,
                        help=f"OMPL's CPU seconds per scene (default {DEFAULT_OMPL_TIME:g}; "
                             f"--quick {QUICK_OMPL_TIME:g})")
    parser.add_argument("--quick", action="store_true", help="a short run to try it out")
    parser.add_argument("--arm", action="append", choices=ARMS, default=None,
                        help="only this arm (repeatable)")
    parser.add_argument("--family", action="append", choices=FAMILIES, default=None,
                        help="only this family (repeatable)")
    parser.add_argument("--no-rigs", action="store_true",
                        help="leave out the arms read from the real rigs")
    parser.add_argument("--output", default=str(ROOT / "bench" / "tight.json"))
    parser.add_argument("--ompl-from", metavar="JSON",
                        help="take OMPL's side from a finished run's JSON (same scenes) and "
                             "plan only Reach's")
    parser.add_argument("--table", metavar="JSON",
                        help="print the table of a finished run's JSON and plan nothing")
    args = parser.parse_args(argv)
    if args.table:
        result = json.loads(Path(args.table).read_text())
        result["summary"] = summary(result["scenes"])
        print(markdown(result))
        return 0
    count = args.count or (QUICK_COUNT if args.quick else DEFAULT_COUNT)
    ompl_time = args.ompl_time or (QUICK_OMPL_TIME if args.quick else DEFAULT_OMPL_TIME)
    arms = tuple(args.arm or (SYNTHETIC_ARMS if args.no_rigs else ARMS))
    families = tuple(args.family or FAMILIES)
    ompl_from = None
    if args.ompl_from:
        ompl_from = json.loads(Path(args.ompl_from).read_text())
        ompl_from["source"] = str(args.ompl_from)
    result = run(count, args.seed, ompl_time, arms, families, output=Path(args.output),
                 ompl_from=ompl_from)
    print()
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
