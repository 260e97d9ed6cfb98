"""Plan as a user waits for it: Blender's interface against the same plan headless.

Debian's Blender 3.4.1 (the binary tests' ``blender``) plans the GUI test's plate scene
(``tests/binary/scripts/build_scene.py``: a real rig, a cup behind a plate) in its
interface under Xvfb — software OpenGL, where every redraw is expensive — and with
``--background``, which runs the pipeline in one go; ``tests/binary/scripts/gui_latency.py``
times each Plan. Each round starts one headless Blender, then one interface; each plans
once untimed (what a session's first Plan warms), then :data:`PLANS` times. Two
settings: ``default`` (what a user gets on this scene: the search guided round the plate)
and ``straight`` (the GUI test's: step 0.04, searched straight at the plate, a longer
search whose progress is drawn while it runs).

Per setting, medians and spread (min–max) over every timed Plan:

- ``gui_wall_s``: in the interface, from invoking Plan to its end (the operator's own
  clock, as the Result shows it); ``gui_shown_s``: until the Result panel was drawn with
  it (the viewport drawing the new trajectory included);
- ``headless_wall_s``: the same Plan headless;
- ``gui_planner_s`` / ``headless_planner_s``: the pipeline's own time, and
  ``search_time_s``: the search's, from the plan's statistics;
- ``ratio``: the interface's wall time over the headless one, the median of each round's
  (medians of the same moment, the machine's load shared), with its spread; goal ≤ 1.5;
- ``redraws_per_s``: the Reach panel's draws while Plan ran (its progress) per second of
  the wall time, in the interface.
"""

from __future__ import annotations

import json
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Timed Plans per Blender session (after one untimed).
PLANS = 3
#: Planner settings set in the panel before planning.
SETTINGS = {"default": {}, "straight": {"step": 0.04, "guide_when_blocked": False}}
TOOLS = ("blender", "xvfb-run", "xdotool")


def _spread(values):
    v = [float(x) for x in values]
    return {"median": statistics.median(v), "min": min(v), "max": max(v), "runs": len(v)}


def _session(profile, scene, folder, settings, gui):
    from binhost import SCRIPTS, output

    args = [scene["path"], "--python", SCRIPTS / "gui_latency.py", "--", folder,
            scene["armature"], scene["target"], PLANS, json.dumps(settings)]
    proc = profile.blender_run_gui(*args, timeout=900) if gui else \
        profile.blender_run("--background", *args, timeout=600)
    path = Path(folder) / "session.json"
    seen = json.loads(path.read_text()) if path.is_file() else {"error": output(proc)}
    if "error" in seen or len(seen.get("plans", ())) != PLANS:
        raise RuntimeError(f"gui latency ({'interface' if gui else 'headless'}): "
                           f"{seen.get('error', seen)}\n{output(proc)}")
    return seen["plans"]


def bench_step(runs: int, log=print) -> dict:
    """The step of ``bench/run.py``: {"gui_latency": {...}} (empty without the tools)."""
    missing = [t for t in TOOLS if shutil.which(t) is None]
    if missing:
        log(f"  skipped: {', '.join(missing)} not found (tools/system-deps.sh)")
        return {}
    for p in (ROOT / "tests", ROOT / "tests" / "binary"):
        if str(p) not in sys.path:
            sys.path.insert(0, str(p))
    from binhost import build_scene, make_profile, output, tagged

    out = {"blender": None, "plans_per_session": PLANS, "rounds": runs}
    with tempfile.TemporaryDirectory(prefix="reach-gui-latency-") as tmp:
        profile, proc = make_profile(Path(tmp) / "profile", shutil.which("blender"))
        tagged(proc, "ENABLED")
        proc, scene = build_scene(profile)
        if proc.returncode != 0:
            raise RuntimeError(f"gui latency: the plate scene was not built\n{output(proc)}")
        out["blender"] = scene["blender"]
        for name, settings in SETTINGS.items():
            gui, headless, ratios = [], [], []
            for r in range(runs):
                bg = _session(profile, scene, Path(tmp) / f"{name}-{r}-headless", settings, False)
                ui = _session(profile, scene, Path(tmp) / f"{name}-{r}-gui", settings, True)
                headless += bg
                gui += ui
                ratios.append(statistics.median(p["time"]["wall_s"] for p in ui)
                              / statistics.median(p["time"]["wall_s"] for p in bg))
                log(f"  {name} round {r + 1}: interface " + ", ".join(
                    f"{1000 * p['time']['wall_s']:.0f}" for p in ui) + " ms, headless " +
                    ", ".join(f"{1000 * p['time']['wall_s']:.0f}" for p in bg) +
                    f" ms: {ratios[-1]:.2f}×")
            row = {
                "settings": settings,
                "gui_wall_s": _spread(p["time"]["wall_s"] for p in gui),
                "gui_shown_s": _spread(p["shown_s"] for p in gui),
                "gui_planner_s": _spread(p["time"]["planner_s"] for p in gui),
                "headless_wall_s": _spread(p["time"]["wall_s"] for p in headless),
                "headless_planner_s": _spread(p["time"]["planner_s"] for p in headless),
                "gui_search_time_s": _spread(p["search_time_s"] for p in gui),
                "headless_search_time_s": _spread(p["search_time_s"] for p in headless),
                "nodes_searched": headless[0]["nodes_searched"],
                "nodes_in_solution": headless[0]["nodes_in_solution"],
                "redraws_per_s": _spread(p["panel_draws_running"] / p["time"]["wall_s"]
                                         for p in gui),
                "ratio": _spread(ratios),
            }
            out[name] = row
            log(f"  {name}: interface {1000 * row['gui_wall_s']['median']:.0f} ms (shown "
                f"{1000 * row['gui_shown_s']['median']:.0f} ms), headless "
                f"{1000 * row['headless_wall_s']['median']:.0f} ms, planner "
                f"{1000 * row['gui_planner_s']['median']:.0f} / "
                f"{1000 * row['headless_planner_s']['median']:.0f} ms: "
                f"{row['ratio']['median']:.2f}× ({row['ratio']['min']:.2f}–"
                f"{row['ratio']['max']:.2f})")
    return {"gui_latency": out}
