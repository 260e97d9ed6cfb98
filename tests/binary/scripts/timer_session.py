"""Drive a scripted interface session from inside Blender: a generator that yields the
seconds to wait before its next step, run by a ``bpy.app.timers`` callback in the live event
loop. When it ends, fails or runs out of time, what it recorded in ``seen`` (with "ok" or
"error") goes to ``OUT/session.json`` and Blender quits."""

import json
import time
import traceback

import bpy


def drive(session, seen, out, deadline_s, first_interval=0.5):
    t_start = time.monotonic()
    deadline = t_start + deadline_s

    def tick():
        try:
            if time.monotonic() > deadline:
                raise RuntimeError("the session ran out of time")
            return next(session)
        except StopIteration:
            seen["ok"] = True
        except Exception:
            seen["error"] = traceback.format_exc()
        seen["seconds"] = round(time.monotonic() - t_start, 2)
        (out / "session.json").write_text(json.dumps(seen, indent=1))
        bpy.ops.wm.quit_blender()
        return None

    out.mkdir(parents=True, exist_ok=True)
    bpy.app.timers.register(tick, first_interval=first_interval)
