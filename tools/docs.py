"""The README's pictures, copied from what the tests and the demo wrote into ``out/``:

* ``docs/gui-panel.png``: the 3D viewport of the GUI test's session under Xvfb (Blender
  3.4.1, ``tests/binary/scripts/gui_session.py``), mid-reach with the red trajectory and
  the sidebar's Reach panel and Result: its ``out/gui/readme.png`` cropped to the viewport
  (the area's rectangle as the session recorded it in ``out/gui/session.json``);
* ``docs/demo-strip.png``: the stills of the demo's six tasks side by side
  (``out/demo-strip.png``, written by ``make demo``);
* ``docs/envelope.png``: the demo character's reach envelope in the workplace
  (``out/envelope.png``, written by ``make demo``).

``make docs`` runs the GUI test and the demo first, then this. Needs ImageMagick
(``convert``), which ``make test``'s system packages include.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT, DOCS = ROOT / "out", ROOT / "docs"


def viewport_crop(session: Path, shot: str) -> str:
    """ImageMagick geometry of the 3D viewport in screenshot ``shot`` of the session."""
    steps = json.loads(session.read_text())["steps"]
    geometry = next(s["geometry"] for s in steps if s["step"] == "screenshot" and s["name"] == shot)
    x, y, w, h = geometry["area"]
    height = geometry["window"][1]
    return f"{w}x{h}+{x}+{height - (y + h)}"


def main() -> int:
    gui = OUT / "gui"
    wanted = [gui / "readme.png", gui / "session.json", OUT / "demo-strip.png",
              OUT / "envelope.png"]
    missing = [str(p.relative_to(ROOT)) for p in wanted if not p.is_file()]
    if missing:
        print(f"missing {', '.join(missing)}: run the GUI test (tests/binary/test_gui_panel.py) "
              "and make demo first (make docs does)", file=sys.stderr)
        return 2
    DOCS.mkdir(exist_ok=True)
    crop = viewport_crop(gui / "session.json", "readme")
    subprocess.run(["convert", str(gui / "readme.png"), "-crop", crop, "+repage",
                    str(DOCS / "gui-panel.png")], check=True, timeout=60)
    for name in ("demo-strip.png", "envelope.png"):
        shutil.copyfile(OUT / name, DOCS / name)
    print(f"wrote docs/gui-panel.png (viewport {crop}), docs/demo-strip.png and docs/envelope.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
