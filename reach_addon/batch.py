r"""Batch studies: many reach tasks over scenes, armatures and targets, on local worker
processes or on a Dask distributed cluster, with one result file per task.

A study is a TOML file (paths relative to it)::

    name = "shelf-envelope"
    output = "results"            # folder for the results (default: <study>-results)
    task = "reach"                # reach | guided
    arm = "right"                 # right | left | auto
    presets = ["Weak"]            # strength / body / rig-map presets, by name
    settings = { step = 0.02 }    # planner settings (reach_addon.core.settings), every task

    [[variants]]                  # optional; each task runs once per variant
    name = "with-body"
    [[variants]]
    name = "no-body"
    settings = { chest_rotation = false }

    [[scenes]]
    file = "workplace.blend"
    armature = "metarig"          # or armatures = ["a", "b"]
    obstacles = "Furniture"       # optional: one collection (default: all visible objects)
    targets = ["Cup", "Jar"]      # objects, listed one by one ...
    [scenes.grid]                 # ... and/or a grid of target points over a region
    frame = "shoulder"            # "shoulder": arm lengths from the reaching shoulder along
                                  # (forward, outward, up) of the character; "world": scene units
    min = [0.2, -0.4, -0.4]
    max = [1.0, 0.6, 0.6]
    count = [5, 6, 6]

Tasks are scenes × armatures × (targets + grid points) × variants. Each is planned, not baked
(``reach bake`` bakes): the pipeline of the add-on runs with drawing and keying off, and the
result records success and reason, the Table 2 statistics, the final pose's strength
category f_R and angles, and the body rotation used — a reach-envelope study reads which
points are reachable, at what strength, with and without body rotation.

Execution: every task runs in a Reach worker process (:mod:`.batch_workers`), ``workers``
of them locally (default: the number of cores), or one per Dask worker of a cluster
(``dask="tls://HOST:PORT"``, :mod:`.batch_cluster`); the work done per task is the same
either way. Results are written by the submitting process as they arrive, one JSON file
per task named by a hash of its specification, atomically (:mod:`.atomic`); a re-run
skips tasks whose result exists. At the end ``summary.csv`` (one row per task) and
``summary.json`` (success rate, times, strength categories, per variant) are written. A
run stopped early (SIGTERM, Ctrl+C: :class:`Progress` says what it did) stops its worker
processes or cancels its Dask futures, keeps every result it wrote and writes no
summary. Setting up a cluster safely: the README's *Batch studies*.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import itertools
import json
import os
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

from . import atomic
from .batch_cluster import connect, dask_security, run_on_cluster
from .batch_workers import run_locally
from .core import ReachError


# --- the study ---------------------------------------------------------------------------

def _grid_points(grid: dict, where: str):
    try:
        lo, hi, count = (list(grid[k]) for k in ("min", "max", "count"))
    except KeyError as exc:
        raise ReachError(f"{where}: a grid needs min, max and count (missing {exc})") from None
    if not (len(lo) == len(hi) == len(count) == 3) or any(int(c) < 1 for c in count):
        raise ReachError(f"{where}: grid min, max and count are three numbers each, counts ≥ 1")
    axes = [[lo[i] + (hi[i] - lo[i]) * (k / (count[i] - 1) if count[i] > 1 else 0.5)
             for k in range(int(count[i]))] for i in range(3)]
    return [list(map(float, p)) for p in itertools.product(*axes)]


def task_id(spec: dict) -> str:
    keys = ("scene", "armature", "target", "point", "frame", "arm", "task", "obstacles",
            "variant", "settings", "bones")
    text = json.dumps({k: spec.get(k) for k in keys}, sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()[:16]


@dataclass
class Study:
    name: str
    path: Path
    output: Path
    specs: list


def load_study(path: Path, output: Path | None = None) -> Study:
    """Read a study file into task specifications (plain JSON-able dicts). Presets are
    resolved into settings and bone names here, once, so workers need no registration."""
    path = Path(path)
    if not path.is_file():
        raise ReachError(f"study file '{path}' not found")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ReachError(f"study file '{path}' is not valid TOML: {exc}") from None
    base = path.parent
    name = data.get("name", path.stem)
    task = data.get("task", "reach")
    if task not in ("reach", "guided"):
        raise ReachError(f"study '{path.name}': task must be reach or guided, not '{task}'")
    arm = data.get("arm", "auto")
    if arm not in ("right", "left", "auto"):
        raise ReachError(f"study '{path.name}': arm must be right, left or auto, not '{arm}'")
    settings, bones = resolve_settings(data.get("presets", []), data.get("settings", {}),
                                       data.get("bones", {}))
    variants = data.get("variants") or [{"name": "default"}]
    scenes = data.get("scenes") or []
    if not scenes:
        raise ReachError(f"study '{path.name}' names no [[scenes]]")
    specs = []
    for i, sc in enumerate(scenes, 1):
        where = f"study '{path.name}', scene {i}"
        if "file" not in sc:
            raise ReachError(f"{where}: give the .blend as file = \"...\"")
        blend = (base / sc["file"]).resolve()
        if not blend.is_file():
            raise ReachError(f"{where}: scene file '{blend}' not found")
        armatures = sc.get("armatures") or ([sc["armature"]] if "armature" in sc else [])
        if not armatures:
            raise ReachError(f"{where}: name the armature (armature = \"...\")")
        grid = sc.get("grid")
        frame = (grid or {}).get("frame", "shoulder")
        if frame not in ("shoulder", "world"):
            raise ReachError(f"{where}: grid frame must be shoulder or world, not '{frame}'")
        if grid and frame == "shoulder" and sc.get("arm", arm) == "auto":
            raise ReachError(f"{where}: a shoulder-frame grid needs arm = \"right\" or \"left\"")
        targets = [{"target": t} for t in sc.get("targets", [])]
        targets += [{"point": p, "frame": frame} for p in (_grid_points(grid, where) if grid else [])]
        if not targets:
            raise ReachError(f"{where}: give targets = [...] or a [scenes.grid]")
        for armature, target, variant in itertools.product(armatures, targets, variants):
            vs, vb = resolve_settings(variant.get("presets", []), variant.get("settings", {}),
                                      variant.get("bones", {}), settings, bones)
            spec = {"scene": str(blend), "armature": armature, "arm": sc.get("arm", arm),
                    "task": task, "obstacles": sc.get("obstacles"),
                    "variant": variant.get("name", "default"), "settings": vs, "bones": vb,
                    "target": None, "point": None, "frame": None, **target}
            spec["id"] = task_id(spec)
            specs.append(spec)
    out = output or (base / data["output"] if "output" in data else base / f"{path.stem}-results")
    return Study(name, path, Path(out), specs)


def resolve_settings(presets, changes: dict, bones: dict, settings: dict | None = None,
                     base_bones: dict | None = None):
    """(settings dict, bone overrides) from presets by name, then explicit changes."""
    from .core import Settings

    current = Settings.from_dict(settings) if settings else Settings()
    bones_out = dict(base_bones or {})
    if presets:
        current, preset_bones = _apply_presets(presets, current)
        bones_out.update(preset_bones)
    try:
        current = current.replace(**changes)
    except (TypeError, ValueError) as exc:
        raise ReachError(f"study settings: {exc}") from None
    bones_out.update(bones)
    return current.to_dict(), bones_out


def _apply_presets(names, settings):
    """Run Blender presets (Python snippets against ``scene.reach``) on a scratch scene."""
    import bpy

    from . import ensure_registered, unregister
    from .ui import presets as presets_mod
    from .ui.properties import bone_overrides, settings_from, settings_to

    registered = ensure_registered()
    scene = bpy.data.scenes.new("Reach presets")
    window_scene = bpy.context.window.scene if bpy.context.window else None
    try:
        if bpy.context.window:
            bpy.context.window.scene = scene
        with bpy.context.temp_override(scene=scene):
            settings_to(scene.reach.settings, settings)
            for name in names:
                presets_mod.apply_named(name)
            out = settings_from(scene.reach.settings)
            bones = bone_overrides(scene.reach)
    finally:
        if window_scene is not None:
            bpy.context.window.scene = window_scene
        bpy.data.scenes.remove(scene)
        if registered:
            unregister()
    return out, bones


# --- running a study ------------------------------------------------------------------------

def result_path(output: Path, spec: dict) -> Path:
    return output / "tasks" / f"{spec['id']}.json"


def finished(output: Path, spec: dict) -> dict | None:
    path = result_path(output, spec)
    try:
        result = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return result if result.get("id") == spec["id"] and "success" in result else None


@dataclass
class Progress:
    """What a run of a study has done so far, for the line the command line prints when
    SIGTERM or Ctrl+C stops it (:meth:`note`). :func:`run_study` fills it in."""

    study: Study | None = None
    written: int = 0                # result files this run has written

    def note(self) -> str:
        """What was and was not done: results are counted on disk (whole files only)."""
        if self.study is None:
            return "nothing was written"
        total = len(self.study.specs)
        done = sum(finished(self.study.output, s) is not None for s in self.study.specs)
        return (f"{self.written} task result(s) written by this run ({done} of {total} "
                f"tasks done in '{self.study.output / 'tasks'}'), {total - done} not done: "
                "a re-run plans only those; no summary written")


def run_study(path: Path, workers: int | None = None, dask: str | None = None,
              output: Path | None = None, out=None, *, tls_ca_file=None, tls_cert=None,
              tls_key=None, insecure_network: bool = False,
              progress: Progress | None = None) -> int:
    """Run a study; returns the exit status (0 all reached, 1 some failed).

    ``dask``: a scheduler's address (else ``workers`` local processes), connected to as
    :func:`dask_security` says, with the TLS files and ``insecure_network`` given here; its
    refusals come before the study is read or anything is written. ``progress`` (optional)
    is kept up to date with what the run has written. A signal or error that stops the run
    leaves every result file whole (:mod:`.atomic`) and no summary written; the Reach
    worker processes are stopped, Dask futures cancelled."""
    out = out or sys.stdout
    progress = progress if progress is not None else Progress()
    security = (dask_security(dask, tls_ca_file, tls_cert, tls_key, insecure_network)
                if dask else None)
    study = load_study(path, output)
    results = {}
    pending = []
    for spec in study.specs:
        r = finished(study.output, spec)
        if r is None:
            pending.append(spec)
        else:
            results[spec["id"]] = r
    client = connect(dask, security) if dask and pending else None
    try:
        return _run(study, pending, results, workers, dask, client, out, progress)
    finally:
        if client is not None:
            client.close(timeout=10)


def _run(study, pending, results, workers, dask, client, out, progress) -> int:
    """Plan ``pending`` (on ``client``'s cluster, else locally), write each result as it
    arrives, then the summaries; ``results`` holds those already done."""
    study.output.mkdir(parents=True, exist_ok=True)
    progress.study = study
    workers = workers or os.cpu_count() or 1
    where = f"Dask cluster {dask}" if dask else f"{min(workers, max(1, len(pending)))} local workers"
    print(f"study '{study.name}': {len(study.specs)} tasks, {len(results)} already done, "
          f"{len(pending)} to run on {where}", file=out, flush=True)
    t0 = time.perf_counter()
    errors = 0
    source = (run_on_cluster(client, pending) if client is not None
              else run_locally(pending, min(workers, max(1, len(pending)))))
    by_id = {s["id"]: s for s in pending}
    with contextlib.closing(source):   # stopped early: the workers stop now, not later
        for n, result in enumerate(source, 1):
            spec = by_id.get(result.get("id"))
            label = _label(spec) if spec else "?"
            if "error" in result or spec is None:
                errors += 1
                print(f"[{n}/{len(pending)}] {label}: ERROR {result.get('error')}", file=out, flush=True)
                continue
            atomic.write_text(result_path(study.output, spec), json.dumps(result, indent=1))
            progress.written += 1
            results[spec["id"]] = result
            state = (f"reached, f_R {result['final_f_r']}" if result["success"]
                     else f"not reached ({result['reason']})")
            print(f"[{n}/{len(pending)}] {label}: {state}", file=out, flush=True)
    wall = time.perf_counter() - t0
    ordered = [results[s["id"]] for s in study.specs if s["id"] in results]
    summary = summarize(study, ordered, wall, dask or f"local:{workers}")
    atomic.write_text(study.output / "summary.json", json.dumps(summary, indent=2))
    atomic.write_text(study.output / "summary.csv", summary_csv(ordered))
    print(f"{summary['succeeded']}/{summary['tasks']} reached "
          f"({100 * summary['success_rate']:.0f} %); results in {study.output}", file=out,
          flush=True)
    if errors:
        print(f"{errors} task(s) stopped with an error and will be retried by a re-run",
              file=out, flush=True)
    return 0 if (not errors and all(r["success"] for r in ordered)) else 1


def _label(spec) -> str:
    what = spec["target"] if spec["target"] else "point (" + ", ".join(
        f"{v:.2f}" for v in spec["point"]) + ")"
    return f"{Path(spec['scene']).name} {spec['armature']} → {what} [{spec['variant']}]"


CSV_FIELDS = ("id", "scene", "armature", "target", "point", "variant", "arm", "success",
              "reason", "final_f_r", "body_rotation_deg", "alpha_deg", "beta_deg", "gamma_deg",
              "elbow_deg", "wrist_error_arm_lengths", "nodes_searched", "nodes_in_solution",
              "path_length_arm_lengths", "mean_f_r", "search_time_s", "preprocess_time_s",
              "planning_time_s", "wall_time_s")


def summary_csv(results) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, CSV_FIELDS, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in results:
        row = dict(r)
        row["scene"] = Path(r["scene"]).name
        row["point"] = " ".join(f"{v:.4f}" for v in r["point"]) if r.get("point") else ""
        for k, v in (r.get("final_angles_deg") or {}).items():
            row[f"{k}_deg"] = round(v, 3)
        w.writerow(row)
    return buf.getvalue()


def _stats(values):
    import numpy as np

    if not values:
        return None
    a = np.array(values, float)
    return {"mean": float(a.mean()), "median": float(np.median(a)), "min": float(a.min()),
            "max": float(a.max())}


def _group(results):
    ok = [r for r in results if r["success"]]
    cats = [0, 0, 0]
    for r in ok:
        cats[r["final_f_r"]] += 1
    return {
        "tasks": len(results), "succeeded": len(ok),
        "success_rate": len(ok) / len(results) if results else 0.0,
        "final_strength_categories": cats,
        "reasons": {k: sum(1 for r in results if r.get("reason") == k)
                    for k in sorted({r.get("reason") for r in results if r.get("reason")})},
        "search_time_s": _stats([r["search_time_s"] for r in ok]),
        "planning_time_s": _stats([r["planning_time_s"] for r in ok]),
        "nodes_searched": _stats([r["nodes_searched"] for r in ok]),
        "path_length_arm_lengths": _stats([r["path_length_arm_lengths"] for r in ok]),
        "body_rotation_deg": _stats([abs(r["final_angles_deg"]["body_rotation"]) for r in ok]),
    }


def summarize(study: Study, results, wall_time_s: float, backend: str) -> dict:
    from . import __version__

    variants = sorted({r["variant"] for r in results})
    return {
        "study": study.name, "file": str(study.path), "reach_version": __version__,
        "blender_version": results[0]["blender_version"] if results else None,
        "backend": backend, "wall_time_s": wall_time_s,
        **_group(results),
        "variants": {v: _group([r for r in results if r["variant"] == v]) for v in variants},
    }
