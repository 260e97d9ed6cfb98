"""The ``reach`` command line: one parser for every host.

* ``python -m reach_addon <command> ...`` with the bpy wheel;
* ``blender --background --command reach <command> ...`` on Blender 4.2+ (registered with
  ``bpy.utils.register_cli_command`` when the add-on is enabled);
* on Blender ≤ 4.1, with Reach installed as a legacy add-on::

      blender --background --python-expr \
        "import sys, reach_addon.cli as c; sys.exit(c.main(sys.argv[sys.argv.index('--') + 1:]))" \
        -- bake scene.blend --armature rig --target Cup --output out.blend

Commands: ``bake`` (one .blend), ``envelope`` (the arm's reach envelope as a CSV, a still
and optionally a mesh), ``batch`` (a study of many tasks, local processes or a
Dask cluster), ``demo`` (the paper's four tasks). Exit status: 0 every task reached its
target; 1 some did not (their reasons are in the report; the others are still baked and
saved); 2 bad input, with one line on stderr naming what is wrong and no output written;
128 + the signal's number (143, 130) when SIGTERM or Ctrl+C stops it, with one line on
stderr saying what was and was not written. Planner settings are flags too (``--step
0.03``, ``--no-chest-rotation``, ...), applied after ``--preset``.

Every file is written atomically (:mod:`.atomic`): to a temporary file in its folder, then
renamed onto its name, so ``--output`` (or the input file, with ``--in-place``) is either
its old self or the complete new file, never part of one, and a stopped run leaves no
temporary file behind.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from . import atomic
from .core import ReachError, Settings
from .core.settings import fields

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2
#: The hand's figures of each task in the report (README, "The report").
HAND_REPORT_KEYS = ("max_wrist_turn_deg_per_frame", "max_hand_turn_deg_per_frame",
                    "mean_wrist_bend_deg", "max_wrist_bend_deg", "inserted_frames",
                    "unbounded_hand_turns", "touching_transitions",
                    # Match orientation (core.orient): null when it was not asked for
                    "orientation_error_deg", "orientation_met")
#: The bake's figures of each baked task (README, "The report"): how far the rig put a
#: planned joint, how far the evaluated wrist ends from the target
#: (blender.results.measure_arrival), and the spans between keys made linear (and still
#: too close after it).
BAKE_REPORT_KEYS = ("rig_residual_arm_lengths", "wrist_gap_arm_lengths", "linear_spans",
                    "close_spans",
                    # the elbow lifted for a low target, and bends an obstacle forced
                    # (blender.results.measure_naturalness)
                    "chicken_wing_frames", "forced_bend_frames", "bend_forced_by")

#: The body's figures of a baked task (README, "The report"), by their names' beginnings:
#: the balance (``com_margin_*``, ``support_from``), the lean and squat (``lean_*``, the
#: other arm's ``lean_other_arm`` among them), the step (``step_*``), the head's turn
#: (``gaze_*``) and the other arm's note.
BODY_REPORT_PREFIXES = ("com_margin", "support_from", "lean_", "step_", "gaze_", "other_arm_",
                        "spine_")


class Interrupted(BaseException):
    """SIGTERM or SIGINT arrived while a command ran. A BaseException, like
    KeyboardInterrupt, so no ``except Exception`` on the way swallows it; files being
    written are abandoned (:mod:`.atomic`) as it passes."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum
        self.name = signal.Signals(signum).name
        self.note = "nothing was written"


@contextmanager
def _interruptible():
    """Turn SIGTERM and SIGINT into :class:`Interrupted` while the block runs (on the main
    thread only: Python handles signals there), then put the previous handlers back. A
    signal whose handler the host installed in C (the Blender program's own;
    ``signal.getsignal`` gives None) is left to the host: Python could not put it back."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, _frame):
        raise Interrupted(signum)

    previous = {s: signal.signal(s, handler) for s in (signal.SIGTERM, signal.SIGINT)
                if signal.getsignal(s) is not None}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


class _Parser(argparse.ArgumentParser):
    """argparse that reports bad usage as a :class:`ReachError` (exit status 2 with one
    line), not by exiting the host process — Blender runs the command in-process."""

    def error(self, message):
        raise ReachError(message)


def _add_settings_flags(parser):
    group = parser.add_argument_group("planner settings (defaults in parentheses)")
    for f in fields():
        flag = "--" + f.name.replace("_", "-")
        meta = dict(f.metadata, doc=f.metadata["doc"].replace("%", "%%"))
        if isinstance(f.default, bool):
            group.add_argument(flag, dest=f"set_{f.name}", action=argparse.BooleanOptionalAction,
                               default=None, help=f"{meta['doc']} ({f.default})")
        else:
            kind = type(f.default)
            group.add_argument(flag, dest=f"set_{f.name}", type=kind, default=None,
                               choices=meta.get("choices"), metavar=meta["unit"].upper() or None,
                               help=f"{meta['doc']} ({f.default})")


def _add_character_args(parser):
    parser.add_argument("--arm", default="auto", choices=("left", "right", "auto"))
    parser.add_argument("--obstacles", metavar="COLLECTION",
                        help="only this collection's objects are obstacles (default: all visible)")
    parser.add_argument("--preset", action="append", default=[], metavar="NAME",
                        help="a strength, body or rig-map preset by name (repeatable)")
    parser.add_argument("--bone", action="append", default=[], metavar="ROLE=BONE",
                        help="set a bone by hand, e.g. upper_arm_right=Arm.R or chest=Spine2")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="reach", description=__doc__.splitlines()[0],
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    bake = sub.add_parser("bake", help="plan and bake reaches in one .blend file")
    bake.add_argument("scene", help="the .blend file to read")
    bake.add_argument("--armature", required=True, help="the character's armature object")
    bake.add_argument("--target", required=True, action="append", dest="targets",
                      help="object to reach for (repeat for several)")
    bake.add_argument("--task", default="reach", choices=("reach", "sequence", "guided", "chase"),
                      help="reach: each target on its own, baked one after another; sequence: "
                           "in order; guided: through guiding nodes; chase: follow the "
                           "target's animation")
    _add_character_args(bake)
    bake.add_argument("--frame-start", type=int, help="first frame (default: the file's current frame)")
    bake.add_argument("--duration", type=float, metavar="SECONDS",
                      help="seconds per reach (default: from the path length)")
    bake.add_argument("--new-action", action="store_true", help="bake into a copy of the action")
    bake.add_argument("--bake-closest", action="store_true",
                      help="bake the closest approach when a target cannot be reached")
    bake.add_argument("--output", help="where to save the result (required unless --in-place)")
    bake.add_argument("--in-place", action="store_true", help="save over the input file")
    bake.add_argument("--report", help="write a JSON report here")
    bake.add_argument("--render", metavar="DIR",
                      help="render a still of the last frame and an MP4 of the motion here")
    _add_settings_flags(bake)
    bake.add_argument("--orient", dest="set_match_orientation", action="store_const", const=True,
                      help="the palm arrives aligned with each target's axes (the same as "
                           "--match-orientation; axes: --finger-axis, --palm-axis=-z)")
    bake.add_argument("--no-step", dest="set_stepping", action="store_const", const=False,
                      help="never step toward a target (the same as --no-stepping)")
    bake.set_defaults(func=cmd_bake)

    env = sub.add_parser("envelope", help="the arm's reach envelope on a grid, as a CSV (and a "
                                          "still): strength category, chest turn, blocked, out")
    env.add_argument("scene", help="the .blend file to read (it is not changed)")
    env.add_argument("--armature", required=True, help="the character's armature object")
    env.add_argument("--target", action="append", default=[], dest="targets",
                     help="an object left out of the obstacles (with --arm auto, the arm "
                          "nearer the first one is taken)")
    _add_character_args(env)
    env.add_argument("--output", required=True, help="the CSV to write (one row per grid point)")
    env.add_argument("--render", metavar="DIR",
                     help="render a still of the envelope (envelope.png) here")
    env.add_argument("--mesh", metavar="BLEND", help="also save the scene with the envelope as a "
                                                     "mesh (per-class materials) to this .blend")
    _add_settings_flags(env)
    env.set_defaults(func=cmd_envelope)

    batch = sub.add_parser("batch", help="run a study of many tasks (see reach_addon.batch)")
    batch.add_argument("study", help="the study's TOML file")
    batch.add_argument("--workers", type=int, default=None,
                       help="local worker processes (default: the number of cores)")
    batch.add_argument("--dask", metavar="tls://HOST:PORT",
                       help="run the tasks on an existing Dask distributed cluster instead "
                            "(tcp:// only to 127.0.0.1, unless --insecure-network)")
    batch.add_argument("--tls-ca-file", metavar="PEM",
                       help="the CA the Dask cluster's certificates are signed by (default: "
                            "Dask's configuration, distributed.comm.tls.ca-file)")
    batch.add_argument("--tls-cert", metavar="PEM",
                       help="this client's certificate, signed by that CA (default: "
                            "distributed.comm.tls.client.cert)")
    batch.add_argument("--tls-key", metavar="PEM",
                       help="the certificate's private key, unless the certificate file "
                            "holds it (default: distributed.comm.tls.client.key)")
    batch.add_argument("--insecure-network", action="store_true",
                       help="allow a plain tcp:// scheduler beyond this machine: anyone who "
                            "can reach its port can run code on every worker")
    batch.add_argument("--output", help="results folder (default: the study's, else next to it)")
    batch.set_defaults(func=cmd_batch)

    demo = sub.add_parser("demo", help="the paper's four tasks, with Table 2 beside the paper's")
    demo.add_argument("--output", default="out", help="folder for demo.blend, renders, report")
    demo.add_argument("--core", action="store_true", help="plan with the core alone (no scene)")
    demo.add_argument("--no-render", action="store_true", help="skip the renders")
    demo.set_defaults(func=cmd_demo)
    return parser


def settings_from_args(args, base: Settings) -> Settings:
    changes = {f.name: getattr(args, f"set_{f.name}") for f in fields()
               if getattr(args, f"set_{f.name}", None) is not None}
    return base.replace(**changes) if changes else base


def _bones(pairs):
    out = {}
    for pair in pairs:
        role, sep, name = pair.partition("=")
        if not sep or not name:
            raise ReachError(f"--bone takes ROLE=BONE (e.g. upper_arm_right=Arm.R), got '{pair}'")
        out[role.strip()] = name.strip()
    return out


def report_dict(outcome, settings: Settings, scene_path, output) -> dict:
    """The JSON report (schema in the README)."""
    import bpy

    from . import __version__

    tasks = []
    for r in outcome.results:
        st = r.stats
        tasks.append({
            "target": r.target, "arm": r.arm, "success": r.success, "reason": r.reason,
            "message": r.message, "method": r.method,
            "frame_start": r.frame_start, "frame_end": r.frame_end,
            "bones_keyed": r.bones_keyed,
            **{k: st[k] for k in ("search_time_s", "preprocess_time_s", "nodes_searched",
                                  "nodes_in_solution", "path_length_arm_lengths")},
            "mean_f_r": st["mean_f_r"], "strength_categories": st["strength_categories"],
            "min_clearance_arm_lengths": st["min_clearance_arm_lengths"],
            "frames": st["frames"], "planning_time_s": st["planning_time_s"],
            "sampling_states": st["sampling_states"],
            **{k: st[k] for k in HAND_REPORT_KEYS if k in st},
            **{k: st[k] for k in BAKE_REPORT_KEYS if k in st},
            **{k: v for k, v in st.items() if k.startswith(BODY_REPORT_PREFIXES)},
        })
    return {
        "reach_version": __version__, "blender_version": bpy.app.version_string,
        "scene": str(scene_path), "output": None if output is None else str(output),
        "armature": outcome.rig.armature_name, "arm": outcome.rig.side,
        "baked": outcome.baked, "action": outcome.action,
        "settings": settings.to_dict(), "tasks": tasks,
        "obstacles": outcome.summary()["obstacles"],
    }


@contextmanager
def _opened(scene_path: Path):
    """``scene_path`` opened (a ReachError if it is no .blend file), with Reach registered
    while it is (unregistered after, if this registered it)."""
    import bpy

    from . import ensure_registered, unregister

    if not scene_path.is_file():
        raise ReachError(f"scene file '{scene_path}' not found")
    try:
        bpy.ops.wm.open_mainfile(filepath=str(scene_path), load_ui=False)
    except RuntimeError as exc:
        raise ReachError(f"cannot open '{scene_path}' as a .blend file: "
                         f"{str(exc).strip().splitlines()[-1]}") from None
    registered = ensure_registered()
    try:
        yield
    finally:
        if registered:
            unregister()


def _settings_and_bones(args):
    """(settings, bone overrides) of the open file's Reach properties after ``--preset``,
    the settings flags and ``--bone``."""
    import bpy

    from .ui import presets
    from .ui.properties import bone_overrides, settings_from

    props = bpy.context.scene.reach
    for name in args.preset:
        presets.apply_named(name)
    overrides = bone_overrides(props)
    overrides.update(_bones(args.bone))
    return settings_from_args(args, settings_from(props.settings)), overrides


def cmd_bake(args) -> int:
    scene_path = Path(args.scene)
    if not scene_path.is_file():
        raise ReachError(f"scene file '{scene_path}' not found")
    if args.in_place and args.output:
        raise ReachError("give either --output or --in-place, not both")
    if not args.in_place and not args.output:
        raise ReachError("--output is required (or --in-place to save over the input)")
    output = scene_path if args.in_place else Path(args.output)
    if not args.in_place and output.resolve() == scene_path.resolve():
        raise ReachError("--output is the input file; use --in-place to save over it")
    _bones(args.bone)                           # bad input: before the file is opened

    written = []
    try:
        with _interruptible(), _opened(scene_path):
            return _bake_open_file(args, scene_path, output, written)
    except Interrupted as exc:
        if written:
            exc.note = "wrote " + ", ".join(f"'{p}'" for p in written) + " and nothing after"
        else:
            kept = [f"'{scene_path}' is unchanged"]
            if output != scene_path:
                kept.insert(0, f"'{output}' " + ("is unchanged" if output.exists()
                                                 else "was not created"))
            exc.note = f"nothing was written ({', '.join(kept)})"
        raise


def _bake_open_file(args, scene_path, output, written) -> int:
    import bpy

    from .blender import pipeline

    settings, overrides = _settings_and_bones(args)
    request = pipeline.Request(
        armature=args.armature, targets=list(args.targets), task=args.task, side=args.arm,
        obstacles=args.obstacles, frame_start=args.frame_start, duration_s=args.duration,
        settings=settings, overrides=overrides, new_action=args.new_action,
        bake_closest=args.bake_closest)

    t0 = time.perf_counter()
    pipeline.validate(bpy.context, request, bake=True)      # bad input: before any output
    print(f"planning {len(request.targets)} target(s) for '{request.armature}' ({request.task})",
          flush=True)
    outcome = pipeline.run(bpy.context, request, bake=True)
    n = len(outcome.results)
    for i, r in enumerate(outcome.results, 1):
        st = r.stats
        state = "reached" if r.success else f"FAILED ({r.reason})"
        print(f"[{i}/{n}] {r.target}: {state}; frames {r.frame_start}-{r.frame_end}; "
              f"{st['nodes_searched']} nodes, {st['search_time_s'] * 1000:.0f} ms search"
              + ("" if r.success else f"; {r.message}"), flush=True)

    atomic.save_blend(output)
    written.append(output)
    report = report_dict(outcome, settings, scene_path, output)
    report["total_time_s"] = time.perf_counter() - t0
    if args.render:
        from .blender.render import render_outcome

        report["renders"] = render_outcome(bpy.context, outcome, Path(args.render))
    if args.report:
        atomic.write_text(Path(args.report), json.dumps(report, indent=2))
        written.append(args.report)
    print(f"saved {output}" + (f", report {args.report}" if args.report else ""), flush=True)
    return EXIT_OK if outcome.success else EXIT_FAILED


def cmd_envelope(args) -> int:
    """The reach envelope of one arm: a CSV, and a still and a .blend with its mesh if
    asked. The input file is not changed."""
    import bpy

    from .blender import envelope as envelope_mod
    from .blender import pipeline
    from .core.envelope import CLASSES

    scene_path = Path(args.scene)
    _bones(args.bone)
    if args.mesh and Path(args.mesh).resolve() == scene_path.resolve():
        raise ReachError("--mesh is the input file; the envelope command does not change it, "
                         "give another path")
    with _interruptible(), _opened(scene_path):
        settings, overrides = _settings_and_bones(args)
        request = pipeline.Request(armature=args.armature, targets=list(args.targets),
                                   side=args.arm, obstacles=args.obstacles, settings=settings,
                                   overrides=overrides, draw=False)
        outcome = pipeline.envelope(bpy.context, request)
        env = outcome.envelope
        counts = env.counts()
        print(f"'{args.armature}' {outcome.rig.side} arm: {len(env.classes)} points in "
              f"{env.time_s:.2f} s: " + ", ".join(f"{counts[c]} {c}" for c in CLASSES),
              flush=True)
        envelope_mod.write_csv(outcome, args.output)
        written = [str(args.output)]
        if args.render or args.mesh:
            envelope_mod.write_mesh(bpy.context, outcome)
        if args.render:
            from .blender.render import render_still

            points, _classes = envelope_mod.drawn(outcome)
            written.append(render_still(bpy.context, outcome.rig, points,
                                        Path(args.render) / "envelope.png"))
        if args.mesh:
            atomic.save_blend(Path(args.mesh))
            written.append(str(args.mesh))
    print("wrote " + ", ".join(written), flush=True)
    return EXIT_OK


def cmd_batch(args) -> int:
    """A study (:func:`.batch.run_study`). Stopped by SIGTERM or Ctrl+C, the one line says
    how many results this run wrote, how many tasks are done and how many are left to a
    re-run (:meth:`.batch.Progress.note`)."""
    from .batch import Progress, run_study

    progress = Progress()
    try:
        with _interruptible():
            return run_study(Path(args.study), workers=args.workers, dask=args.dask,
                             output=Path(args.output) if args.output else None,
                             tls_ca_file=args.tls_ca_file, tls_cert=args.tls_cert,
                             tls_key=args.tls_key, insecure_network=args.insecure_network,
                             progress=progress)
    except Interrupted as exc:
        exc.note = progress.note()
        raise


def cmd_demo(args) -> int:
    from . import demo

    if args.core:
        return demo.core_demo(sys.stdout)
    return demo.scene_demo(Path(args.output), render=not args.no_render)


def main(argv=None) -> int:
    """Run one command; returns the exit status (never raises for bad input)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        import bpy  # noqa: F401  (mathutils and the BVH come with it)
    except ImportError:
        print("reach: Blender's Python module is missing; install it with "
              "'pip install bpy==5.0.1' (Python 3.11) or run inside Blender", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        args = build_parser().parse_args(argv)
        return args.func(args)
    except SystemExit as exc:  # --help, --version: argparse is done, the host keeps running
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    except ReachError as exc:
        print(f"reach: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Interrupted as exc:
        print(f"reach: stopped by {exc.name}; {exc.note}", file=sys.stderr, flush=True)
        return 128 + exc.signum


def blender_command(argv) -> int:
    """``blender -c reach ...``: the callback given to ``bpy.utils.register_cli_command``."""
    return main(list(argv))
