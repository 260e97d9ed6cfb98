"""``make fuzz``: the fuzz campaign's runner and its command line.

``python bench/fuzz.py [--count N] [--seed0 S] [--jobs J] [--out FILE] [--subframes N]
[--timeout S] [--cross-check-budget S] [--quick] [--standard-rigs] [--lean] [--resume DIR]`` runs
seeds ``S`` … ``S + N - 1`` on ``J`` worker processes
(:func:`verification.fuzz.campaign.run_campaign`), prints its progress and writes their
summary (:func:`verification.fuzz.summary.summarize`) to ``--out`` (``out/fuzz.json``;
``make fuzz`` gives ``bench/fuzz.json``, so a run of a few seeds leaves that file alone);
exit status 0 when every scene passed, else 1. With ``--resume DIR`` (``make fuzz`` gives
``out/fuzz-runs``) the results are kept in a folder of ``DIR`` named for the code and the
settings (:func:`campaign_folder`), so a campaign stopped part way (Ctrl+C, a closed
session) carries on where it stopped when run again on the same code; other code starts
a folder of its own.
``--keep DIR`` runs the seeds in this process, keeps each scene's files in ``DIR`` and prints
its description, outcome and cross-check. The scenes, the checks and the outcome
categories are :mod:`verification.fuzz`'s; why: ``docs/design.md``, *The fuzz campaign*.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from verification.fuzz.campaign import code_digest, kept_results, run_campaign, worker  # noqa: E402
from verification.fuzz.checks import CROSS_CHECK_BUDGET_S, SUBFRAMES  # noqa: E402
from verification.fuzz.scenes import generate  # noqa: E402
from verification.fuzz.summary import summarize  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=10000, help="scenes (default 10000)")
    parser.add_argument("--seed0", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="worker processes (default: the number of cores)")
    parser.add_argument("--out", default=str(ROOT / "out" / "fuzz.json"),
                        help="results file (default out/fuzz.json; make fuzz writes the "
                             "committed bench/fuzz.json)")
    parser.add_argument("--subframes", type=int, default=SUBFRAMES,
                        help=f"instants checked between two frames (default {SUBFRAMES})")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per scene at most")
    parser.add_argument("--keep", metavar="DIR",
                        help="run in this process and keep each scene's files in DIR (for one seed)")
    parser.add_argument("--cross-check-budget", type=float, default=CROSS_CHECK_BUDGET_S,
                        metavar="SECONDS",
                        help="OMPL's seconds per refusal in the cross-check where a goal "
                             f"region exists (default {CROSS_CHECK_BUDGET_S:g}; 0: no "
                             "cross-check)")
    parser.add_argument("--standard-rigs", action="store_true",
                        help="synthetic rigs as before their shapes varied (A pose, one hand "
                             "bone): replays a seed of an older campaign")
    parser.add_argument("--resume", metavar="DIR",
                        help="keep results in a folder of DIR named for the code and settings, "
                             "and run only the seeds it lacks")
    parser.add_argument("--quick", action="store_true",
                        help="the cheaper scenes of the tests' subset (smaller search budgets)")
    parser.add_argument("--lean", action="store_true",
                        help="every scene with Lean on (and with it Squat): the body reaches "
                             "past the arm where it can")
    args = parser.parse_args(argv)

    seeds = list(range(args.seed0, args.seed0 + args.count))
    if args.keep:
        return _run_kept(args, seeds)

    def progress(done, total, elapsed, state={"last": 0.0}):   # noqa: B006
        if elapsed - state["last"] >= 30 or done == total:
            state["last"] = elapsed
            print(f"fuzz: {done}/{total} scenes, {elapsed:.0f} s", flush=True)

    from bench.tight import git_commit

    commit = git_commit()       # before the run: what the workers import from disk
    settings = {"subframes": args.subframes, "quick": args.quick,
                "cross_check_budget_s": args.cross_check_budget,
                "rig_shapes": not args.standard_rigs, "lean": args.lean}
    runs, sessions = None, []
    if args.resume:
        runs = campaign_folder(Path(args.resume), settings)
        sessions = _sessions(runs)
        kept = len(set(kept_results(runs)) & set(seeds)) if runs.exists() else 0
        print(f"fuzz: results kept in {runs}" + (f"; {kept} of these scenes ran before, at "
              f"{', '.join(sorted({s['commit'] for s in sessions}))}" if kept else ""),
              flush=True)
    t0 = time.perf_counter()
    try:
        results = run_campaign(seeds, args.jobs, args.subframes, args.timeout, progress,
                               args.quick, args.cross_check_budget, not args.standard_rigs,
                               runs, args.lean)
    finally:
        if runs is not None:
            sessions.append({"commit": commit, "jobs": args.jobs,
                             "wall_time_s": round(time.perf_counter() - t0, 1)})
            atomic_json(runs / "sessions.json", sessions)
    import bpy  # noqa: F401  (the versions below)

    from reach_addon import __version__

    commits = sorted({s["commit"] for s in sessions}) if sessions else [commit]
    meta = {"generated_by": "bench/fuzz.py (make fuzz)", "reach_version": __version__,
            "reach_commit": ", ".join(commits),
            "blender_version": bpy.app.version_string, "seed0": args.seed0, "count": args.count,
            "jobs": args.jobs, **settings,
            "wall_time_s": round(sum(s["wall_time_s"] for s in sessions), 1) if sessions
            else round(time.perf_counter() - t0, 1)}
    if len(sessions) > 1:
        meta["sessions"] = len(sessions)
    summary = summarize(results, meta)
    from reach_addon import atomic

    atomic.write_text(Path(args.out), json.dumps(summary, indent=1, ensure_ascii=False) + "\n")
    cats = ", ".join(f"{k} {v['count']}" for k, v in summary["categories"].items() if v["count"])
    if summary["body"]:
        print("fuzz: the whole body reached " + ", ".join(f"{n} by {k}" for k, n in
                                                           summary["body"].items()))
    print(f"fuzz: {summary['passed']}/{len(results)} passed ({cats}); refusals cross-checked "
          f"{summary['refusals_cross_checked']}, false refusals {summary['false_refusals']}, "
          f"undecided {summary['refusals_not_decided']} ({summary['cross_check_seconds']:.0f} s "
          f"of cross-check); wrote {args.out}")
    return 0 if summary["passed"] == len(results) else 1


def _run_kept(args, seeds) -> int:
    """``--keep DIR``: the seeds in this process, each scene's files kept in DIR, and its
    description, outcome and cross-check printed."""
    keep = Path(args.keep).resolve()
    keep.mkdir(parents=True, exist_ok=True)
    results_path = keep / "results.jsonl"
    results_path.unlink(missing_ok=True)
    worker(seeds, results_path, args.subframes, keep=keep, quick=args.quick,
           cross_check_s=args.cross_check_budget, shapes=not args.standard_rigs, lean=args.lean)
    for seed in seeds:
        print(json.dumps(generate(seed, args.quick, not args.standard_rigs, args.lean),
                         indent=1))
    for line in results_path.read_text().splitlines():
        rec = json.loads(line)
        if "category" in rec:
            print(f"seed {rec['seed']}: {rec['category']}: {rec['detail']}")
            if rec.get("traceback"):
                print(rec["traceback"])
            for c in rec.get("cross_check", ()):
                print(f"  cross-check '{c['target']}' {c['reason']}: {c['status']} "
                      f"({c['seconds']:.2f} s): {c['detail']}")
    return 0


def campaign_folder(root: Path, settings: dict) -> Path:
    """The folder of ``root`` that keeps a campaign's results: named for
    :func:`~verification.fuzz.campaign.code_digest` and the settings that change an outcome,
    so only a campaign of the same code and settings carries it on."""
    key = json.dumps(settings, sort_keys=True).encode()
    return root / f"{code_digest()[:16]}-{hashlib.sha256(key).hexdigest()[:8]}"


def _sessions(runs: Path) -> list:
    path = runs / "sessions.json"
    return json.loads(path.read_text()) if path.exists() else []


def atomic_json(path: Path, value) -> None:
    from reach_addon import atomic

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic.write_text(path, json.dumps(value, indent=1) + "\n")


if __name__ == "__main__":
    sys.exit(main())
