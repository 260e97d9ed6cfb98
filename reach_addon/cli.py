"""The ``reach`` command line.

``python -m reach_addon <command>`` (with the bpy wheel). Bad input is one line on stderr
and exit status 2.
"""

from __future__ import annotations

import argparse
import sys


def _require_blender():
    """mathutils (BVH trees) comes with Blender: import bpy, or say how to get it."""
    try:
        import bpy  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise SystemExit(
            "reach: Blender's Python module is missing; install it with "
            "'pip install bpy==5.0.1' (Python 3.11) or run inside Blender") from exc


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="reach", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="plan the paper's four tasks and print Table 2")
    demo.set_defaults(func=_cmd_demo)
    return parser


def _cmd_demo(args) -> int:
    from .demo import core_demo

    return core_demo(sys.stdout)


def main(argv=None) -> int:
    _require_blender()
    from .core import ReachError

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ReachError as exc:
        print(f"reach: {exc}", file=sys.stderr)
        return 2
