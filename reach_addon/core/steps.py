"""Step generators: how the core's long computations report progress.

A planner stage that may take long is a generator: it yields its progress now and then
and returns its result (``return value`` inside the generator, ``StopIteration.value``
outside). A caller that must stay responsive (a modal operator, live mode) advances it a
slice at a time; every other caller runs it to the end with :func:`drain`.
"""

from __future__ import annotations


def drain(steps):
    """Run a step generator to its end and return its value."""
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def relay(steps, report):
    """Re-yield a step generator's progress as ``report(progress)`` and return its value
    (``yield from`` with the progress translated)."""
    while True:
        try:
            progress = next(steps)
        except StopIteration as done:
            return done.value
        yield report(progress)
