"""The fuzz campaign's runs: one scene from seed to outcome, and seeds on worker processes.

:func:`run_scene` generates, builds, bakes twice and checks one seed and returns its result
(JSON: ``seed``, ``features``, ``task``, ``rig``, ``category`` of
:data:`verification.fuzz.checks.CATEGORIES`, ``detail``, ``exit_status``, ``time_s`` and the
``timings`` of each stage in seconds; ``reasons``, ``cross_check``, ``warnings`` and
``traceback`` where there are any). :func:`run_campaign` runs seeds on worker processes
(``python -m verification.fuzz.campaign``, each a Blender of its own) and returns the results
in seed order; a worker that dies or stalls gives its scene ``escaped_exception`` or
``timeout`` and is restarted on the seeds after it. Given a ``runs`` folder, the workers'
result files are kept there and a later call with the same folder runs only the seeds it
lacks (:func:`code_digest` says whether the code is still the same). ``bench/fuzz.py``
(``make fuzz``) and ``tests/blender/test_fuzz.py`` call it; :mod:`verification.fuzz.summary`
counts the results.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

from .. import ROOT
from .building import RigCache, build, make_library
from .checks import (CROSS_CHECK_BUDGET_S, SUBFRAMES, bake_argv, classify, cross_check, digest,
                     keyed_values, run_cli, verify)
from .scenes import generate


#: The exit statuses of a bake that SIGTERM or Ctrl+C stopped (128 + the signal's number).
STOPPED = (143, 130)


class StoppedError(Exception):
    """A scene's bake was stopped by a signal (the campaign being stopped): the scene has
    no result, and runs again when the campaign is resumed. Fuzz seeds 621 and 5514 of
    the campaign at 11ae6bb were recorded as "nondeterministic" when a pause's SIGTERM
    stopped their second bake (exit status 143)."""


def run_scene(seed: int, scene_dir: Path, cache: RigCache, library: Path,
              subframes: int = SUBFRAMES, quick: bool = False,
              cross_check_s: float = CROSS_CHECK_BUDGET_S, shapes: bool = True,
              lean: bool = False) -> dict:
    """Generate, build, bake twice and check one scene, its refusals cross-checked
    (:func:`cross_check`, OMPL given ``cross_check_s`` seconds each; 0 skips it); returns
    its result (JSON). ``quick``, ``shapes``, ``lean``: as :func:`generate` takes them. Raises
    :class:`StoppedError` where a signal stopped a bake."""
    import bpy

    t0 = time.perf_counter()
    spec = generate(seed, quick, shapes, lean)
    result = {"seed": int(seed), "features": spec["features"], "task": spec["task"],
              "rig": spec["rig"]["kind"] if spec["rig"]["kind"] != "synthetic"
              else f"synthetic/{spec['rig']['map']}"}
    for p in scene_dir.glob("*"):
        if p.name != library.name and p.suffix in (".blend", ".blend1", ".json"):
            p.unlink()
    try:
        manifest = build(spec, cache, scene_dir, library)
    except Exception:   # noqa: BLE001
        tb = traceback.format_exc()
        result.update(category="generator_error", detail=tb.strip().splitlines()[-1], traceback=tb,
                      time_s=time.perf_counter() - t0)
        return result
    timings = {"build": time.perf_counter() - t0}
    before = {f: digest(f) for f in manifest["files"]}
    runs = []
    for k in (1, 2):
        output, report = scene_dir / f"output{k}.blend", scene_dir / f"report{k}.json"
        run = run_cli(bake_argv(spec, manifest, output, report))
        if run["rc"] in STOPPED:
            raise StoppedError(seed)
        run["report"] = json.loads(report.read_text()) if report.exists() else None
        run["output"] = output
        runs.append(run)
        timings[f"bake{k}"] = time.perf_counter() - t0 - sum(timings.values())
    changed = [f for f, h in before.items() if not Path(f).exists() or digest(f) != h]
    keys, problems = [[], []], []
    try:
        if all(r["exception"] is None for r in runs):
            for k, run in enumerate(runs):
                if run["output"].exists():
                    bpy.ops.wm.open_mainfile(filepath=str(run["output"]), load_ui=False)
                    keys[k] = keyed_values()
            timings["keys"] = time.perf_counter() - t0 - sum(timings.values())
            if runs[1]["report"] is not None and runs[1]["rc"] in (0, 1):
                problems = verify(manifest, runs[1]["report"], runs[1]["output"], subframes)
        category, detail = classify(spec, manifest, runs, changed, keys, problems)
        timings["check"] = time.perf_counter() - t0 - sum(timings.values())
        if category == "failure_with_reason" and runs[0]["rc"] == 1 and cross_check_s > 0:
            checks = cross_check(spec, manifest, runs[0]["report"], cross_check_s)
            result["cross_check"] = checks
            false = [c for c in checks if c["status"] == "false_refusal"]
            if false:
                c = false[0]
                category, detail = "false_refusal", f"'{c['target']}' {c['reason']}: {c['detail']}"
            timings["cross_check"] = time.perf_counter() - t0 - sum(timings.values())
    except Exception:   # noqa: BLE001
        tb = traceback.format_exc()
        category, detail = "generator_error", "checking: " + tb.strip().splitlines()[-1]
        result["traceback"] = tb
    if category == "escaped_exception":
        result["traceback"] = next(r["exception"] for r in runs if r["exception"])
    timings.setdefault("check", time.perf_counter() - t0 - sum(timings.values()))
    result["timings"] = {k: round(v, 3) for k, v in timings.items()}
    if runs[0]["warnings"]:
        result["warnings"] = runs[0]["warnings"]
    result.update(category=category, detail=detail, exit_status=runs[0]["rc"],
                  time_s=round(time.perf_counter() - t0, 3))
    if runs[0]["report"] is not None:
        result["reasons"] = [t["reason"] for t in runs[0]["report"]["tasks"]]
        body = body_outcomes(runs[0]["report"])
        if body:
            result["body"] = body
    return result


#: How far down (arm lengths) the hips must come for the fuzz to count a lean a squat (the
#: report's own threshold, ``blender.lean.SQUAT_REPORTED``).
SQUAT_DOWN = 0.05


def body_outcomes(report: dict) -> list:
    """What the whole body did for each task of a bake's ``report`` that it did something
    for: "lean" or "squat" (the hips down by :data:`SQUAT_DOWN` arm lengths or more), with
    "+ready" where the arm rose first (``lean_ready_frames``); "step" (``step_count``)
    before either where the body stepped first, alone where it then only reached."""
    out = []
    for stats in report.get("tasks", ()):        # each task's statistics, flattened
        kind = "step" if stats.get("step_count") else ""
        if stats.get("lean_deg"):
            lean = "squat" if stats.get("lean_hips_down", 0.0) >= SQUAT_DOWN else "lean"
            kind = (kind + "+" if kind else "") + lean + (
                "+ready" if stats.get("lean_ready_frames") else "")
        if kind:
            out.append(kind)
    return out


def worker(seeds: list, results: Path, subframes: int, keep: Path | None = None,
           quick: bool = False, cross_check_s: float = CROSS_CHECK_BUDGET_S,
           shapes: bool = True, lean: bool = False) -> None:
    """Run ``seeds`` one after another in this process, appending to ``results`` a line
    ``{"seed": s, "event": "start"}`` before each scene and its result after it."""
    os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="reach-fuzz-user-")
    import bpy  # noqa: F401  (mathutils for the core)

    from reach_addon import ensure_registered

    ensure_registered()
    work = Path(tempfile.mkdtemp(prefix="reach-fuzz-"))
    try:
        scene_dir = keep if keep is not None else work / "scene"
        scene_dir.mkdir(parents=True, exist_ok=True)
        library = scene_dir / "library.blend"
        make_library(library)
        cache = RigCache(work)
        with open(results, "a", encoding="utf-8") as out:
            for seed in seeds:
                out.write(json.dumps({"seed": int(seed), "event": "start"}) + "\n")
                out.flush()
                try:
                    result = run_scene(int(seed), scene_dir, cache, library, subframes, quick,
                                       cross_check_s, shapes, lean)
                except StoppedError:
                    break          # no result: the scene runs again on resume
                out.write(json.dumps(result) + "\n")
                out.flush()
    finally:
        if keep is None:
            shutil.rmtree(work, ignore_errors=True)


def _worker_command(seeds: list, results: Path, subframes: int, quick: bool,
                    cross_check_s: float = CROSS_CHECK_BUDGET_S, shapes: bool = True,
                    lean: bool = False) -> list:
    return [sys.executable, "-m", "verification.fuzz.campaign", "--results", str(results),
            "--subframes", str(subframes), "--seeds", ",".join(str(s) for s in seeds),
            "--cross-check-budget", repr(float(cross_check_s))] + \
        (["--quick"] if quick else []) + ([] if shapes else ["--standard-rigs"]) + \
        (["--lean"] if lean else [])


#: This module, left out of :func:`code_digest`.
_SCHEDULER = "verification/fuzz/campaign.py"


def code_digest(root: Path = ROOT) -> str:
    """SHA-256 over the files a scene's outcome depends on: the add-on
    (``reach_addon/**/*.py``) and the checks (``verification/**/*.py``), less this module,
    which only schedules them. Two campaigns with the same digest bake and judge every seed
    alike, so one may carry on the other's results."""
    h = hashlib.sha256()
    files = sorted(p for d in ("reach_addon", "verification") for p in (root / d).rglob("*.py")
                   if p.relative_to(root).as_posix() != _SCHEDULER)
    for p in files:
        h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()


def kept_results(runs: Path) -> dict:
    """The results by seed that the worker files in ``runs`` hold (a scene started but not
    finished is not one of them: it runs again)."""
    done: dict = {}
    for path in sorted(runs.glob("worker-*.jsonl")):
        done.update(_read_results(path)[0])
    return done


def _read_results(path: Path) -> tuple:
    """(results by seed, the last seed started without a result) of a worker's file."""
    done, started = {}, None
    if path.exists():
        for line in path.read_text(encoding="utf-8").splitlines():
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue        # a line being written
            if rec.get("event") == "start":
                started = rec["seed"]
            else:
                done[rec["seed"]] = rec
    return done, (started if started is not None and started not in done else None)


def run_campaign(seeds, jobs: int = 2, subframes: int = SUBFRAMES, timeout_s: float = 600.0,
                 progress=None, quick: bool = False,
                 cross_check_s: float = CROSS_CHECK_BUDGET_S, shapes: bool = True,
                 runs: Path | None = None, lean: bool = False) -> list:
    """Run ``seeds`` on ``jobs`` worker processes, each taking a contiguous range; returns
    the results in seed order. A worker that dies or stalls past ``timeout_s`` on one
    scene gives that seed ``escaped_exception`` or ``timeout`` and is restarted on the
    seeds after it. ``cross_check_s``: OMPL's seconds per refusal of the cross-check (0:
    none); ``quick``, ``shapes``, ``lean``: as :func:`generate` takes them. ``runs``: a folder that
    keeps the workers' result files; the seeds whose results it already holds
    (:func:`kept_results`) are not run again. The caller makes sure they came from the same
    code and settings (``bench/fuzz.py --resume``)."""
    seeds = [int(s) for s in seeds]
    results: dict = {}
    if runs is not None:
        runs.mkdir(parents=True, exist_ok=True)
        wanted = set(seeds)
        results = {s: r for s, r in kept_results(runs).items() if s in wanted}
    todo = [s for s in seeds if s not in results]
    if not todo:
        return [results[s] for s in seeds]
    jobs = max(1, min(jobs, len(todo)))
    bounds = np.linspace(0, len(todo), jobs + 1).round().astype(int)
    queues = [todo[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    tmp = Path(tempfile.mkdtemp(prefix="reach-fuzz-runs-"))
    out_dir = runs if runs is not None else tmp
    workers = {}
    t_start = time.monotonic()

    def launch(k, queue):
        path = out_dir / f"worker-{k}-{len(queue)}-{queue[0]}.jsonl"
        log = open(tmp / f"worker-{k}.log", "ab")
        proc = subprocess.Popen(_worker_command(queue, path, subframes, quick, cross_check_s,
                                                shapes, lean),
                                cwd=ROOT,
                                stdout=subprocess.DEVNULL, stderr=log, start_new_session=True)
        workers[k] = {"proc": proc, "path": path, "queue": queue, "log": log,
                      "seen": 0, "last": time.monotonic(), "started": None}

    try:
        for k, q in enumerate(queues):
            if q:
                launch(k, q)
        while workers:
            time.sleep(0.5)
            for k in list(workers):
                w = workers[k]
                done, pending = _read_results(w["path"])
                results.update(done)
                if len(done) != w["seen"] or pending != w["started"]:
                    w["seen"], w["started"], w["last"] = len(done), pending, time.monotonic()
                rc = w["proc"].poll()
                stalled = rc is None and time.monotonic() - w["last"] > timeout_s
                if rc is None and not stalled:
                    continue
                if stalled:
                    os.killpg(w["proc"].pid, 9)
                    w["proc"].wait()
                w["log"].close()
                rest = [s for s in w["queue"] if s not in results]
                del workers[k]
                if rest:
                    lost = pending if pending is not None else rest[0]
                    tail = (tmp / f"worker-{k}.log").read_text(errors="replace").strip().splitlines()
                    why = (f"no result within {timeout_s:.0f} s" if stalled else
                           f"the process died (status {rc}): " + (tail[-1] if tail else ""))
                    spec = generate(lost, quick, shapes, lean)
                    results[lost] = {"seed": lost, "features": spec["features"], "task": spec["task"],
                                     "rig": spec["rig"]["kind"],
                                     "category": "timeout" if stalled else "escaped_exception",
                                     "detail": why, "exit_status": None, "time_s": None}
                    rest = [s for s in rest if s != lost]
                    if rest:
                        launch(k, rest)
            if progress is not None:
                progress(len(results), len(seeds), time.monotonic() - t_start)
    finally:
        for w in workers.values():
            try:
                os.killpg(w["proc"].pid, 9)
            except ProcessLookupError:
                pass
        shutil.rmtree(tmp, ignore_errors=True)
    return [results[s] for s in seeds if s in results]


def main(argv=None) -> int:
    """A worker process: ``python -m verification.fuzz.campaign --results FILE --seeds
    1,2,3 [--subframes N] [--cross-check-budget S] [--quick] [--standard-rigs] [--lean]``
    (:func:`worker`)."""
    parser = argparse.ArgumentParser(description="one worker of the fuzz campaign")
    parser.add_argument("--results", required=True)
    parser.add_argument("--seeds", required=True)
    parser.add_argument("--subframes", type=int, default=SUBFRAMES)
    parser.add_argument("--cross-check-budget", type=float, default=CROSS_CHECK_BUDGET_S)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--standard-rigs", action="store_true")
    parser.add_argument("--lean", action="store_true")
    args = parser.parse_args(argv)
    worker([int(s) for s in args.seeds.split(",")], Path(args.results), args.subframes,
           quick=args.quick, cross_check_s=args.cross_check_budget,
           shapes=not args.standard_rigs, lean=args.lean)
    return 0


if __name__ == "__main__":
    sys.exit(main())
