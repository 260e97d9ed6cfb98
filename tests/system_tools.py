"""The one rule for tests that need tools from outside Python (a Blender binary, Xvfb,
xdotool, ImageMagick, numpy in Blender's own Python): without them a test skips on a
developer's machine, and fails under continuous integration, with the same message naming
what is missing and how to install it (``tools/system-deps.sh``). CI is told apart by the
environment variable ``CI`` (CI runs with ``CI=true``): set to anything but an empty
string, ``0``, ``false`` or ``no``, a missing tool is a failure."""

from __future__ import annotations

import os
import shutil

import pytest

#: The Debian package of each tool.
PACKAGES = {"blender": "blender", "xvfb-run": "xvfb", "xdotool": "xdotool",
            "convert": "imagemagick", "numpy": "python3-numpy"}


def under_ci() -> bool:
    """Is this run continuous integration (``CI`` set, and not to a false value)?"""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def missing(what: list[str]):
    """Fail under CI, else skip, naming what is missing and how to install it."""
    pkgs = " ".join(sorted({PACKAGES[w] for w in what}))
    msg = (f"{', '.join(what)} not available: run tools/system-deps.sh "
           f"(apt-get install -y {pkgs})")
    if under_ci():
        pytest.fail(msg, pytrace=False)
    pytest.skip(msg)


def require(*tools: str):
    """:func:`missing` for those of the command-line ``tools`` that are not on the PATH."""
    absent = [t for t in tools if shutil.which(t) is None]
    if absent:
        missing(absent)
