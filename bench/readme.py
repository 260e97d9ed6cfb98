"""Write the README's Performance table from ``bench/results.json`` (``make bench`` runs
this after ``bench/run.py``; a row from ``bench/compare.py``'s ``bench/compare.json`` where
there is one) and its fuzz campaign's counts from ``bench/fuzz.json``
(``make fuzz`` runs it after ``bench/fuzz.py``; the words are
:func:`verification.fuzz.summary.fuzz_counts`), so the figures there are the bench's,
never copied by hand.

    python bench/readme.py [--check]

The table sits between the markers ``<!-- bench:start -->`` and ``<!-- bench:end -->``, the
counts between ``<!-- fuzz:start -->`` and ``<!-- fuzz:end -->``. ``--check`` exits 1 if
the README's figures are not the ones the results give.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from verification.fuzz.summary import fuzz_counts  # noqa: E402

START, END = "<!-- bench:start -->", "<!-- bench:end -->"
FUZZ_START, FUZZ_END = "<!-- fuzz:start -->", "<!-- fuzz:end -->"
TASKS = ("collision_free", "rotation", "guided", "chase")


def _per_task(rows, key, fmt="{:.0f}", scale=1.0):
    by = {r["task"]: r for r in rows}
    return " / ".join(fmt.format(scale * by[t][key])
                      if t in by and by[t].get(key) is not None else "–" for t in TASKS)


def _pairs(rows, a, b, joint, fmt="{:.0f}"):
    """Per task "a<joint>b", tasks separated by " / "."""
    by = {r["task"]: r for r in rows}
    return " / ".join(f"{fmt.format(by[t][a])}{joint}{fmt.format(by[t][b])}" if t in by else "–"
                      for t in TASKS)


def _range(values, fmt="{:.1f}"):
    values = [v for v in values if v is not None]
    if not values:
        return "–"
    lo, hi = fmt.format(min(values)), fmt.format(max(values))
    return lo if lo == hi else f"{lo}–{hi}"


def _ms(seconds) -> str:
    return "–" if seconds is None else f"{1000 * seconds:.0f}"


def table(r: dict, compare: dict | None = None) -> str:
    m = r["machine"]
    t2, race = r.get("table2", []), r.get("ompl", [])
    paper = {row["task"]: row for row in t2}
    lines = [f"On the {m['cores']}-core {m['cpu']} machine of `bench/results.md` (Reach "
             f"{r['reach_version']}, bpy {r['blender_version']}, medians of {r['runs']} runs, "
             f"{r['date']}); tasks (a) collision-free, (b) rotation, (c) guided, (d) chase:",
             "", "| figure | Reach | paper / goal |", "|---|---|---|"]
    if t2:
        lines.append(f"| Table 2 search (a–d) | {_per_task(t2, 'search_time_s', scale=1000)} ms | "
                     + " / ".join(f"{1000 * paper[t]['paper_search_time_s']:.0f}" for t in TASKS
                                  if t in paper) + " ms (paper, 2005 PC) |")
        lines.append(f"| speed-up over the paper's search (a–d) | "
                     f"{_per_task(t2, 'speedup_vs_paper', '{:.0f}×')} | goal ≥ 150× |")
        lines.append(f"| nodes searched (a–d) | {_per_task(t2, 'nodes_searched')} | "
                     + " / ".join(str(paper[t]["paper_nodes_searched"]) for t in TASKS
                                  if t in paper) + " |")
        lines.append(f"| µs per node searched (a–d) | "
                     f"{_per_task(t2, 'time_per_node_ms', scale=1000)} | different hardware and "
                     "problem: " + " / ".join(
                         f"{1e6 * paper[t]['paper_search_time_s'] / paper[t]['paper_nodes_searched']:.0f}"
                         for t in TASKS if t in paper) + " (paper) |")
        if all("planning_time_s" in row for row in t2):
            lines.append(f"| whole plan: search, smoothing, timing, the hand (a–d) | "
                         f"{_per_task(t2, 'planning_time_s', scale=1000)} ms | |")
        prep = [row["preprocess_time_s"] * 1000 for row in t2 if row["preprocess_time_s"] > 0]
        lines.append(f"| workspace preprocessing | {_range(prep, '{:.0f}')} ms | goal ≤ 60 ms |")
        if all("max_wrist_turn_deg_per_frame" in row for row in t2):
            lines.append(f"| the hand's largest turn in a frame, relative to the forearm (a–d) | "
                         f"{_per_task(t2, 'max_wrist_turn_deg_per_frame', '{:.1f}')}° | "
                         "bound 15° at 24 fps |")
            lines.append(f"| … its whole turn in space, the forearm's turn and roll included "
                         f"(a–d) | {_per_task(t2, 'max_hand_turn_deg_per_frame', '{:.1f}')}° | "
                         "bound 15° at 24 fps |")
            if all("chicken_wing_frames" in row for row in t2):
                lines.append(
                    "| naturalness (a–d): mean / max wrist bend from the rest alignment, "
                    "chicken-wing frames, mean f_R | " + " / ".join(
                        f"{row['mean_wrist_bend_deg']:.1f}°, {row['max_wrist_bend_deg']:.1f}°, "
                        f"{row['chicken_wing_frames']}, {row['mean_f_r']:.2f}" for row in t2)
                    + " | RULA: a wrist beyond 15° from neutral is a risk; no wing |")
            else:
                lines.append(f"| mean wrist bend (a–d) | "
                             f"{_per_task(t2, 'mean_wrist_bend_deg', '{:.1f}')}° | |")
            lines.append(f"| transitions touching between keys, turns over the bound (a–d) | "
                         f"{_pairs(t2, 'touching_transitions', 'unbounded_hand_turns', ', ')} "
                         "| 0, 0 |")
    if "chase_update_ms_p50" in r:
        lines.append(f"| live update, p50 / p95 | {r['chase_update_ms_p50']:.1f} / "
                     f"{r['chase_update_ms_p95']:.1f} ms | goal p95 ≤ 16 ms |")
    if "bake_1000_frames_ms" in r:
        lines.append(f"| bake, 1000 frames × {r['bake_bones']} bones (all the bake keys on the "
                     f"metarig) | {r['bake_1000_frames_ms']:.0f} ms | goal ≤ 50 ms |")
    if r.get("scaling"):
        sc = r["scaling"]
        lines.append("| search against " + " / ".join(f"{s['triangles'] / 1000:,.0f}k" for s in sc)
                     + " triangles | " + " / ".join(f"{1000 * s['search_time_s']:.0f}" for s in sc)
                     + " ms | BVH build " + " / ".join(f"{1000 * s['bvh_build_time_s']:.0f}"
                                                       for s in sc) + " ms |")
    if "gather_10k_instances_ms" in r:
        lines.append(f"| obstacles from a 10,000-instance scatter | "
                     f"{r['gather_10k_instances_ms']:.0f} ms | |")
    for label, o in (r.get("obstacles_ready") or {}).items():
        what = (f"one mesh object of {o['triangles'] / 1e6:.1f}M triangles in reach"
                if label == "one_object" else
                f"{o['objects']} of {o.get('objects_in_scene', o['objects'])} objects in reach, "
                f"{o['triangles'] / 1e6:.2f}M triangles")
        floor = o.get("blender_build_ms")
        floor = "" if not floor else ("; Blender's own BVH build of it alone: " + ", ".join(
            f"{k} {v['median']:.0f}" for k, v in floor.items()) + " ms")
        lines.append(f"| obstacles ready for a Plan in Blender, {what}: first build / again, "
                     f"nothing changed | {o['first_build_ms']:.0f} / {o['ready_again_ms']:.0f} ms "
                     f"| goal ≤ 250 ms{floor} |")
    gui = r.get("gui_latency") or {}
    for name, g in ((k, v) for k, v in gui.items() if isinstance(v, dict)):
        lines.append(
            f"| Plan in Blender {gui['blender']}'s interface (Xvfb, software OpenGL) / headless, "
            f"plate scene, {name} settings: wall, interface / headless | "
            f"{1000 * g['gui_wall_s']['median']:.0f} / {1000 * g['headless_wall_s']['median']:.0f}"
            f" ms, {g['ratio']['median']:.2f}× ({g['ratio']['min']:.2f}–{g['ratio']['max']:.2f})"
            f"; planner {1000 * g['gui_planner_s']['median']:.0f} ms in the interface | "
            "goal ≤ 1.5× |")
    if "batch_1proc_s" in r:
        runs, work = r.get("batch_runs_s"), r.get("batch_work_s")
        each = ""
        if runs and work and len(runs["1"]) == len(runs["2"]) == 2:
            # the tasks' summed time: between runs alike (drift) and two at once against one
            drift = max(max(w) / min(w) for w in work.values())
            ratio = (sum(work["2"]) / 2) / (sum(work["1"]) / 2)
            each = (" (runs in order 1, 2, 2, 1: " + ", ".join(
                f"{x:.1f}" for x in (runs["1"][0], runs["2"][0], runs["2"][1], runs["1"][1]))
                + f" s; each task takes {ratio:.2f}× as long with two processes at once; "
                f"runs alike differ by up to {drift:.2f}×)")
        lines.append(f"| {r.get('batch_tasks', '')}-task batch study, 1 → 2 worker processes | "
                     f"{r['batch_1proc_s']:.1f} → {r['batch_2proc_s']:.1f} s "
                     f"({r['batch_speedup_2proc']:.2f}×){each} | goal ≥ 1.8× |")
    if r.get("everyday"):
        ev = r["everyday"]
        lines.append("| everyday reaches (" + ", ".join(e["scene"] for e in ev) + "): nodes "
                     "searched / nodes in path | " + " / ".join(
                         f"{e['nodes_searched']}/{e['nodes_in_solution']} ({e['ratio']:.1f}×"
                         + ("" if e["method"] == "best-first" else f", {e['method'] or e['reason']}")
                         + ")" for e in ev) + " | goal ≤ 3× |")
    if race:
        lines.append("| vs OMPL RRTConnect (+ simplification): OMPL time / Reach's whole plan, "
                     f"grid included (a–d) | {_per_task(race, 'time_ratio_ompl_over_reach', '{:.2f}')}"
                     " | same problem, goal region, checker and clock; medians of "
                     f"{_range([x.get('runs') for x in race], '{:.0f}')} seeds, runs where both "
                     "pass the independent check |")
        lines.append(f"| Reach / OMPL wrist path length (a–d) | "
                     f"{_per_task(race, 'path_ratio_reach_over_ompl', '{:.2f}')} | |")
        lines.append(f"| mean f_R, Reach vs OMPL (a–d) | "
                     f"{_pairs(race, 'reach_mean_f_r', 'ompl_mean_f_r', ' vs ', '{:.2f}')} | |")
        lines.append(f"| interpolated samples touching, Reach vs OMPL (a–d) | "
                     f"{_pairs(race, 'reach_collisions', 'ompl_collisions', ' vs ')} | 0 |")
    if compare:
        per = " / ".join(f"{row['paired_ratio']:.2f}" for row in compare["rows"])
        same = sum(row["same_plan"] for row in compare["rows"])
        warm = ", warm" if compare.get("warm") else ""
        lines.append(
            f"| whole plan, Reach at {compare['head']} over Reach at {compare['base']} on one "
            f"clock (`bench/compare.py`: {compare['rounds']} paired rounds{warm}; Table 2 (a–d), then "
            f"the everyday reaches {', '.join(r['task'] for r in compare['rows'][4:])}) | "
            f"{per}; geometric mean {compare['geometric_mean_paired_ratio']:.2f}×; Python "
            f"calls {compare['geometric_mean_calls_ratio']:.3f}× | "
            f"{same} of {len(compare['rows'])} plans identical; ≤ 1 is no slower |")
    tight = (r.get("tight") or {}).get("summary", {}).get("total")
    if tight:
        commit = r["tight"].get("reach_commit")
        saved = ROOT / "bench" / "tight.json"
        if commit is None and saved.exists():      # results.json from before it was kept there
            commit = json.loads(saved.read_text()).get("reach_commit")
        lines.append(
            f"| tight scenes (`bench/tight.json`, Reach at {commit or '?'}): "
            "Reach's successes among the scenes OMPL solves; median time, Reach's whole plan "
            "/ its search alone / OMPL's solve | "
            f"{tight['reach_solved']} of {tight['ompl_solved']} ({100 * tight['reach_rate']:.1f} %)"
            f" of {tight['scenes']}; {1000 * tight['reach_median_s']:.0f} / "
            f"{_ms(tight.get('reach_median_search_s'))} / "
            f"{1000 * tight['ompl_median_s']:.0f} ms | goal ≥ 99 %, median well under OMPL's |")
    return "\n".join(lines)


def _between(text: str, start: str, end: str, body: str) -> str | None:
    if start not in text or end not in text:
        return None
    head, rest = text.split(start, 1)
    _old, tail = rest.split(end, 1)
    return f"{head}{start}\n{body}\n{end}{tail}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true")
    parser.add_argument("--results", default=str(ROOT / "bench" / "results.json"))
    parser.add_argument("--fuzz", default=str(ROOT / "bench" / "fuzz.json"))
    parser.add_argument("--compare", default=str(ROOT / "bench" / "compare.json"))
    args = parser.parse_args(argv)
    results = json.loads(Path(args.results).read_text())
    compare = json.loads(Path(args.compare).read_text()) if Path(args.compare).exists() else None
    fuzz = json.loads(Path(args.fuzz).read_text())
    readme = ROOT / "README.md"
    text = readme.read_text()
    new = text
    for start, end, body in ((START, END, table(results, compare)),
                             (FUZZ_START, FUZZ_END, fuzz_counts(fuzz))):
        new = _between(new, start, end, body)
        if new is None:
            print(f"README.md has no {start} … {end} markers", file=sys.stderr)
            return 2
    if args.check:
        return 0 if new == text else 1
    readme.write_text(new)
    print("README.md: Performance table and fuzz counts written from", args.results, "and",
          args.fuzz)
    return 0


if __name__ == "__main__":
    sys.exit(main())
