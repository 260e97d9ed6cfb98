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

Execution. Blender's Python module must run on a process's main thread, so every task runs
in a *Reach worker process*: a persistent child (``python -c ...`` with the bpy wheel, or
``blender -b --python-expr ...`` under the Blender binary) that reads one task per line on
stdin and answers with one JSON line. Locally, ``workers`` such children (default: the
number of cores) take tasks as they free up. With ``dask="tls://HOST:PORT"`` the tasks are
submitted to an existing Dask distributed cluster; each Dask worker process keeps one Reach
worker child, so the work done per task is exactly the local one and the results are the
same. Every machine needs Python 3.11, the bpy wheel, numpy, dask[distributed] and Reach
importable — the scheduler too, it unpickles the task graph — and the scene files at the
same paths.

A Dask scheduler runs whatever it is sent: anyone who can connect to its port can run any
code, as the user the cluster runs as, on the scheduler and every worker. So every
connection uses TLS, each side showing a certificate of the farm's own CA
(:func:`dask_security`: the CA, certificate and key from the flags or Dask's
configuration), and a plain ``tcp://`` address beyond the loopback is refused unless
``insecure_network`` accepts that risk. With a CA ``farm-ca.pem`` and a key and certificate
signed by it, ``farm.key`` and ``farm.pem`` (the README's ``openssl`` commands make them),
``SCHED`` the scheduler's address on the farm network and ``ME`` each worker machine's
own (both 127.0.0.1 for a trial on one machine)::

    TLS="--tls-ca-file farm-ca.pem --tls-cert farm.pem --tls-key farm.key"
    PYTHONPATH=/path/to/reach dask scheduler --host $SCHED --port 8786 \
        --dashboard-address 127.0.0.1:8787 $TLS
    PYTHONPATH=/path/to/reach dask worker tls://$SCHED:8786 --host $ME --nworkers 4 \
        --nthreads 1 --dashboard-address 127.0.0.1:0 $TLS
    python -m reach_addon batch study.toml --dask tls://$SCHED:8786 $TLS

``--host`` binds each process to the farm's interface alone, ``--dashboard-address`` keeps
Dask's HTTP pages (no login) on the loopback. One thread per Dask worker process is
enough: its Reach worker child does the work.

Results are written by the submitting process as they arrive, one JSON file per task named
by a hash of its specification, atomically (:mod:`.atomic`: a temporary file renamed into
place); a re-run skips tasks whose result exists. At the end ``summary.csv`` (one row per task) and
``summary.json`` (success rate, times, strength categories, per variant) are written. A run
stopped early (SIGTERM, Ctrl+C: :class:`Progress` says what it did) stops its Reach worker
processes or cancels its Dask futures, keeps every result it wrote and writes no summary.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import itertools
import json
import os
import queue
import subprocess
import sys
import threading
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

from . import atomic
from .core import ReachError

MARK = "@@reach-result "
PACKAGE_PARENT = Path(__file__).resolve().parent.parent
PACKAGE = __package__ or "reach_addon"


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


# --- one task, inside a Reach worker process ---------------------------------------------------

_open_file = None


def run_task(spec: dict) -> dict:
    """Plan one task in this process (Blender's main thread) and return its result."""
    import bpy
    import numpy as np

    from . import __version__
    from .blender import pipeline
    from .blender import rig as rig_mod
    from .core import Settings
    from .core.envelope import CLASSES, shoulder_frame_to_canonical

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
            point = np.array(spec["point"], float)
            if spec["frame"] == "shoulder":       # as the reach envelope places its points
                armature = pipeline.find_object(spec["armature"], "armature")
                arm = rig_mod.build(armature, spec["arm"], spec["bones"]).arm
                point = arm.to_world_points(shoulder_frame_to_canonical(arm, point))
            added = bpy.data.objects.new("Reach Study Target", None)
            added.location = point.tolist()
            context.scene.collection.objects.link(added)
            context.view_layer.update()
            target = added.name
        request = pipeline.Request(
            armature=spec["armature"], targets=[target], task=spec["task"], side=spec["arm"],
            obstacles=spec["obstacles"], settings=settings, overrides=spec["bones"], draw=False)
        outcome = pipeline.run(context, request, bake=False)
        # the target's class in the reach envelope (same rig, obstacles and settings)
        classed = pipeline.envelope(context, request, world=[np.array(
            pipeline.find_object(target, "target").matrix_world.translation)]).envelope
        plan, _first = outcome.plans[-1]
        r = outcome.results[-1]
        final = plan.poses[-1]
        wrist = plan.wrist_trajectory()[-1]
        goal = plan.task.targets[-1]
        st = r.stats
        result.update({
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
        })
    except ReachError as exc:
        result.update(success=False, reason="bad_input", message=str(exc))
    finally:
        if added is not None:
            bpy.data.objects.remove(added)
    result["wall_time_s"] = time.perf_counter() - t0
    return result


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
            ".batch import worker_loop; worker_loop()")
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


def _local(specs, workers: int):
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


#: Dask's address schemes whose connections are encrypted and authenticated (TLS).
ENCRYPTED_SCHEMES = ("tls", "wss")


def is_loopback(host: str) -> bool:
    """True when ``host`` (an address's host part) is this machine's loopback interface:
    127.0.0.0/8, ::1 (or ::ffff:127.x.y.z) or ``localhost``. Other names are not looked
    up: a name is taken for a network address, whatever it resolves to."""
    import ipaddress

    if host.lower().rstrip(".") == "localhost":
        return True
    try:
        ip = ipaddress.ip_address(host)
    except ValueError:
        return False
    mapped = getattr(ip, "ipv4_mapped", None)
    return ip.is_loopback or bool(mapped and mapped.is_loopback)


def insecure_address_message(address: str) -> str:
    """The refusal of a plain (unencrypted) ``address`` that is not loopback: the risk, and
    the two ways on."""
    return (f"refusing --dask {address}: a plain connection is neither encrypted nor "
            "authenticated, and a Dask scheduler runs whatever task graph it is sent, so "
            "anyone who can reach that port can run any code on the scheduler and on "
            "every worker, as the user they run as; use tls://HOST:PORT with "
            "--tls-ca-file, --tls-cert and --tls-key (README: Batch studies), or accept "
            "that risk with --insecure-network")


def dask_security(address: str, tls_ca_file=None, tls_cert=None, tls_key=None,
                  insecure_network: bool = False):
    """How to connect to the Dask scheduler at ``address``; no connection is tried.

    Inputs: the ``--dask`` address (``tls://HOST:PORT``, ``tcp://HOST:PORT``, or
    ``HOST:PORT``, which Dask reads as its default scheme, tcp), the TLS files given as
    flags (paths to PEM files; None: not given) and ``--insecure-network``.

    Returns a ``distributed.security.Security`` for a ``tls://`` (or ``wss://``) address:
    the CA file, the client certificate and its key are the flags where given, else Dask's
    configuration (``distributed.comm.tls.ca-file``, ``distributed.comm.tls.client.cert``
    and ``.key``: a YAML file in ``~/.config/dask/`` or ``DASK_DISTRIBUTED__COMM__TLS__...``
    variables); encryption is required and the files are loaded here. Returns None for a
    plain address on the loopback interface (:func:`is_loopback`), or anywhere with
    ``insecure_network``.

    Raises ReachError (one line) for a plain address elsewhere without
    ``insecure_network`` (:func:`insecure_address_message`), TLS flags with a plain
    address, a TLS address without a CA or certificate, or TLS files that are missing or
    do not load; and when the distributed package is missing."""
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
        from distributed.security import Security
    except ImportError:
        raise ReachError("--dask needs the distributed package: pip install "
                         "'dask[distributed]'") from None
    try:
        scheme, loc = parse_address(address)
        host, _port = parse_host_port(loc, default_port=8786)
    except ValueError as exc:
        raise ReachError(f"--dask {address}: {exc}") from None
    given = {"--tls-ca-file": tls_ca_file, "--tls-cert": tls_cert, "--tls-key": tls_key}
    if scheme not in ENCRYPTED_SCHEMES:
        if any(given.values()):
            flags = ", ".join(k for k, v in given.items() if v)
            raise ReachError(f"{flags} given, but --dask {address} is a plain {scheme}:// "
                             "address: write it tls://HOST:PORT")
        if not (insecure_network or is_loopback(host)):
            raise ReachError(insecure_address_message(address))
        return None
    chosen = {k: v for k, v in (("tls_ca_file", tls_ca_file), ("tls_client_cert", tls_cert),
                                ("tls_client_key", tls_key)) if v}
    security = Security(require_encryption=True, **chosen)
    missing = [(flag, key) for flag, key, value in (
        ("--tls-ca-file", "distributed.comm.tls.ca-file", security.tls_ca_file),
        ("--tls-cert", "distributed.comm.tls.client.cert", security.tls_client_cert))
        if not value]
    if missing:
        raise ReachError(f"--dask {address} needs the cluster's CA and a certificate signed "
                         "by it, with its key: give "
                         + " and ".join(flag for flag, _ in missing) + " (and --tls-key), "
                         "or set " + " and ".join(key for _, key in missing)
                         + " (and .client.key) in Dask's configuration")
    for flag, value in (("--tls-ca-file", security.tls_ca_file),
                        ("--tls-cert", security.tls_client_cert),
                        ("--tls-key", security.tls_client_key)):
        if value and "\n" not in value and not Path(value).is_file():
            raise ReachError(f"{flag}: file '{value}' not found")
    try:
        security.get_connection_args("client")      # loads the CA, certificate and key
    except (OSError, ValueError) as exc:            # ssl.SSLError is an OSError
        raise ReachError(f"the TLS files do not load (CA '{security.tls_ca_file}', "
                         f"certificate '{security.tls_client_cert}', key "
                         f"'{security.tls_client_key}'): {exc}") from None
    return security


def connect(address: str, security):
    """A ``distributed.Client`` of the scheduler at ``address``, connected with
    ``security`` (:func:`dask_security`); a ReachError (one line) if it cannot connect or
    the TLS handshake fails."""
    from distributed import Client

    try:
        return Client(address, security=security, timeout=20)
    except OSError as exc:
        raise ReachError(_connect_error(address, exc)) from None


def _dask(client, specs):
    """Yield results of ``specs`` from the cluster of ``client`` as they finish. Stopped
    early (a signal, an error), the futures not yet done are cancelled."""
    from distributed import as_completed

    futures = []
    try:
        futures = client.map(dask_task, specs, key=[f"reach-{s['id']}" for s in specs],
                             pure=False)
        ids = {f.key: s["id"] for f, s in zip(futures, specs)}
        for fut in as_completed(futures):
            try:
                yield fut.result()
            except Exception as exc:
                yield {"id": ids[fut.key], "error": f"{type(exc).__name__}: {exc}"}
    finally:
        if any(not f.done() for f in futures):
            client.cancel(futures)


def _connect_error(address: str, exc: OSError) -> str:
    """One line for a failed connection to the scheduler: Dask's reason without its
    connection description, and for a refused TLS handshake what to check."""
    reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    reason = reason.rpartition(">: ")[2]
    if "SSL" in reason or "certificate" in reason:
        return (f"the Dask scheduler at {address} and this client did not accept each "
                f"other's TLS certificates ({reason}): --tls-cert must be signed by the CA "
                "the cluster trusts, and --tls-ca-file must be the CA that signed the "
                "scheduler's certificate")
    return f"cannot reach the Dask scheduler at {address}: {reason}"


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
    source = (_dask(client, pending) if client is not None
              else _local(pending, min(workers, max(1, len(pending)))))
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
