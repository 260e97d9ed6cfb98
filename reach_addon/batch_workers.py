"""Reach worker processes: a persistent child that plans one batch task per line of its
stdin and answers with one JSON line (:func:`worker_loop`, :func:`run_task`), the local
pool of them (:func:`run_locally`), and the child each Dask worker keeps
(:func:`dask_task`).

Blender's Python module must run on a process's main thread, so every task runs in such a
child: ``python -c ...`` with the bpy wheel, or ``blender -b --python-expr ...`` under
the Blender binary (:func:`worker_command`).
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

from .core import ReachError

MARK = "@@reach-result "


PACKAGE_PARENT = Path(__file__).resolve().parent.parent


PACKAGE = __package__ or "reach_addon"


_open_file = None


def run_task(spec: dict) -> dict:
    """Plan one task (a spec of :func:`.batch.load_study`) in this process (Blender's main
    thread) and return its result: the spec's identity, then success, reason, message,
    the target's envelope class, the final pose's f_R and angles (degrees), the wrist's
    error (arm lengths), the Table 2 statistics and the times (s); bad input gives
    success False, reason ``bad_input``. The scene file is opened once for the tasks
    that follow in it; nothing is saved."""
    import bpy

    from . import __version__
    from .blender import pipeline
    from .core import Settings

    global _open_file
    t0 = time.perf_counter()
    result = {"id": spec["id"], "scene": spec["scene"], "armature": spec["armature"],
              "target": spec["target"], "point": spec["point"], "frame": spec["frame"],
              "variant": spec["variant"], "task": spec["task"], "arm": spec["arm"],
              "reach_version": __version__, "blender_version": bpy.app.version_string}
    added = None
    try:
        if _open_file != spec["scene"]:
            bpy.ops.wm.open_mainfile(filepath=spec["scene"], load_ui=False)
            _open_file = spec["scene"]
        context = bpy.context
        settings = Settings.from_dict(spec["settings"])
        target = spec["target"]
        if target is None:
            added = _point_target(context, spec)
            target = added.name
        request = pipeline.Request(
            armature=spec["armature"], targets=[target], task=spec["task"], side=spec["arm"],
            obstacles=spec["obstacles"], settings=settings, overrides=spec["bones"], draw=False)
        outcome = pipeline.run(context, request, bake=False)
        result.update(_planned(context, request, outcome, target))
    except ReachError as exc:
        result.update(success=False, reason="bad_input", message=str(exc))
    finally:
        if added is not None:
            bpy.data.objects.remove(added)
    result["wall_time_s"] = time.perf_counter() - t0
    return result


def _point_target(context, spec):
    """An Empty at the spec's grid point (world, or the shoulder frame's arm lengths as the
    reach envelope places its points), linked to the scene; the caller removes it."""
    import bpy
    import numpy as np

    from .blender import pipeline
    from .blender import rig as rig_mod
    from .core.envelope import shoulder_frame_to_canonical

    point = np.array(spec["point"], float)
    if spec["frame"] == "shoulder":       # as the reach envelope places its points
        armature = pipeline.find_object(spec["armature"], "armature")
        arm = rig_mod.build(armature, spec["arm"], spec["bones"]).arm
        point = arm.to_world_points(shoulder_frame_to_canonical(arm, point))
    added = bpy.data.objects.new("Reach Study Target", None)
    added.location = point.tolist()
    context.scene.collection.objects.link(added)
    context.view_layer.update()
    return added


def _planned(context, request, outcome, target) -> dict:
    """The result fields of a planned task (:func:`run_task`) from its ``outcome`` and the
    target's class in the reach envelope (same rig, obstacles and settings)."""
    import numpy as np

    from .blender import pipeline
    from .core.envelope import CLASSES

    classed = pipeline.envelope(context, request, world=[np.array(
        pipeline.find_object(target, "target").matrix_world.translation)]).envelope
    plan, _first = outcome.plans[-1]
    r = outcome.results[-1]
    final = plan.poses[-1]
    wrist = plan.wrist_trajectory()[-1]
    goal = plan.task.targets[-1]
    st = r.stats
    return {
        "target_position": [float(v) for v in goal],
        "arm": r.arm, "success": r.success, "reason": r.reason, "message": r.message,
        "arm_length": float(outcome.rig.arm.arm_length),
        "envelope_class": CLASSES[int(classed.classes[0])],
        "envelope_f_r": int(classed.f_r[0]),
        "final_f_r": int(final.f_r),
        "final_angles_deg": dict(zip(("body_rotation", "alpha", "beta", "gamma", "elbow"),
                                     map(float, final.config.as_array()))),
        "wrist_error_arm_lengths": float(np.linalg.norm(wrist - goal)
                                         / outcome.rig.arm.arm_length),
        **{k: st[k] for k in ("search_time_s", "preprocess_time_s", "planning_time_s",
                              "nodes_searched", "nodes_in_solution",
                              "path_length_arm_lengths", "mean_f_r", "frames")},
        # Match orientation (settings = { match_orientation = true }): null when off
        "orientation_error_deg": st["orientation_error_deg"],
        "orientation_met": st["orientation_met"],
    }


def worker_loop(stdin=None, stdout=None):
    """A Reach worker process: one task spec per line in, one result line out."""
    stdin = stdin or sys.stdin
    stdout = stdout or sys.stdout
    for line in stdin:
        if not line.strip():
            continue
        spec = json.loads(line)
        try:
            result = run_task(spec)
        except Exception as exc:  # reported to the study, which keeps going
            import traceback

            result = {"id": spec.get("id"), "error": f"{type(exc).__name__}: {exc}",
                      "traceback": traceback.format_exc()}
        stdout.write(MARK + json.dumps(result) + "\n")
        stdout.flush()


def worker_command() -> list:
    """The command line that starts a Reach worker process under the current host."""
    import bpy

    code = (f"import sys; sys.path.insert(0, {str(PACKAGE_PARENT)!r}); "
            f"from {PACKAGE.rsplit('.', 1)[-1] if PACKAGE.startswith('bl_ext.') else PACKAGE}"
            ".batch_workers import worker_loop; worker_loop()")
    if getattr(bpy.app, "module", False) or not bpy.app.binary_path:
        return [sys.executable, "-c", code]
    return [bpy.app.binary_path, "--background", "--factory-startup", "--python-expr", code]


class WorkerProcess:
    """One persistent Reach worker child and the pipe protocol to it."""

    def __init__(self):
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(worker_command(), stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                     text=True, env=env, cwd=str(PACKAGE_PARENT))

    def run(self, spec: dict) -> dict:
        if self.proc.poll() is not None:
            raise RuntimeError(f"Reach worker exited with status {self.proc.returncode}")
        self.proc.stdin.write(json.dumps(spec) + "\n")
        self.proc.stdin.flush()
        for line in self.proc.stdout:
            if line.startswith(MARK):
                return json.loads(line[len(MARK):])
        raise RuntimeError(f"Reach worker exited with status {self.proc.wait()} "
                           f"while planning task {spec['id']}")

    def terminate(self):
        """Stop the child now (SIGTERM, then SIGKILL after 10 s), whatever it is doing."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def close(self):
        """Let the child finish: end of input, then up to 30 s to exit."""
        if self.proc.poll() is None:
            self.proc.stdin.close()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()


_dask_worker = None


_dask_lock = threading.Lock()


def dask_task(spec: dict) -> dict:
    """Run on a Dask worker: the task goes to this worker's own Reach worker child."""
    global _dask_worker
    with _dask_lock:
        if _dask_worker is None or _dask_worker.proc.poll() is not None:
            _dask_worker = WorkerProcess()
        return _dask_worker.run(spec)


def run_locally(specs, workers: int):
    """Yield results of ``specs`` from ``workers`` Reach worker children, as they finish.
    Closed or stopped early (a signal, an error), no further task starts and the children
    are terminated."""
    todo = queue.Queue()
    for s in specs:
        todo.put(s)
    done = queue.Queue()
    stop = threading.Event()
    lock = threading.Lock()
    children = []

    def serve():
        proc = None
        try:
            while not stop.is_set():
                try:
                    spec = todo.get_nowait()
                except queue.Empty:
                    return
                try:
                    if proc is None or proc.proc.poll() is not None:
                        with lock:                  # no child starts once stop is set
                            if stop.is_set():
                                return
                            proc = WorkerProcess()
                            children.append(proc)
                    done.put(proc.run(spec))
                except Exception as exc:
                    done.put({"id": spec["id"], "error": f"{type(exc).__name__}: {exc}"})
        finally:
            if proc is not None:
                proc.close()

    threads = [threading.Thread(target=serve, daemon=True) for _ in range(max(1, workers))]
    for t in threads:
        t.start()
    try:
        for _ in specs:
            while True:         # a timed wait: the main thread sees a signal within 0.5 s
                try:
                    result = done.get(timeout=0.5)
                    break
                except queue.Empty:
                    pass
            yield result
        for t in threads:
            t.join()
    finally:
        with lock:
            stop.set()
        for proc in children:
            proc.terminate()
        for t in threads:
            t.join(timeout=10)
