"""Files that appear only complete: every file the command line and batch studies write
(the output .blend, reports, per-task results, summaries) is written to a temporary file in
the destination's folder and renamed onto the destination (``os.replace``, atomic on one
file system). A run that stops half way — an error, SIGTERM, Ctrl+C — leaves the
destination as it was (absent, or its previous complete version) and removes its
temporary file.

Kept apart from :mod:`.cli` and :mod:`.batch` so that both import it and neither imports
the other for it. ``bpy`` is imported only by :func:`save_blend`.
"""

from __future__ import annotations

import os
import uuid
from contextlib import contextmanager
from pathlib import Path


def _temp_name(path: Path) -> Path:
    """A hidden name in ``path``'s folder that no file has: ``.<name>.<random>.tmp<suffix>``
    (the suffix kept, so Blender sees a .blend; the name new, so Blender makes no
    ``.blend1`` backup of it)."""
    while True:
        tmp = path.parent / f".{path.stem}.{uuid.uuid4().hex[:12]}.tmp{path.suffix}"
        if not tmp.exists():
            return tmp


def _fsync(path: Path):
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextmanager
def replacing(path):
    """``with replacing(dest) as tmp:`` write ``tmp``; when the block ends normally ``tmp``
    is flushed to disk and renamed onto ``dest``. If the block raises (any exception,
    KeyboardInterrupt and the command line's SIGTERM included) ``tmp`` and what a writer
    may have left beside it (Blender's ``tmp@`` and ``tmp1``) are removed and ``dest`` is
    untouched."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _temp_name(path)
    leftovers = (tmp, tmp.with_name(tmp.name + "@"), tmp.with_name(tmp.name + "1"))
    try:
        yield tmp
        _fsync(tmp)
        os.replace(tmp, path)
    except BaseException:
        for p in leftovers:
            try:
                p.unlink()
            except FileNotFoundError:
                pass
        raise


def write_text(path, text: str):
    """Write ``text`` to ``path`` atomically."""
    with replacing(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)


def save_blend(path):
    """Save the open Blender file as a copy at ``path``, atomically. The open file keeps
    its own path (``copy=True``); relative paths are remapped for the destination's folder,
    which is the temporary file's folder too."""
    import bpy

    path = Path(path).resolve()
    with replacing(path) as tmp:
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp), copy=True)
        if not tmp.is_file():
            raise OSError(f"Blender did not write '{tmp}'")
