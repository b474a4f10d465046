"""Python's cyclic garbage collector, paused while a stage builds millions of small objects.

Reading, simplifying and writing a country-sized file allocate millions of
tuples, streets and geometries that live until the stage ends and form no
reference cycles (plain reference counting frees them). The cyclic
collector still walks every live object on each full collection, and their
number grows with the file, so its cost grows faster than the file: 17 s of
the 56 s that ``osm-expand simplify`` took on the 3 M-node benchmark file,
with the same output and the same peak memory without it. The main
command's run pauses it too: the engine's years keep a town of tens of
thousands of streets, lots and buildings alive and make almost no cyclic
garbage (Krems' default run: 802 objects collected in all), yet the
collector walked them 6,700 times on Campo Grande's default run, 4.2 s of
its 91 s of CPU (Krems: 0.3 s of 11), with the same output and the same peak
memory without it. Reference counting is untouched; anything cyclic is
collected once the pause ends. It is process state, so only the command
line and the batch worker that runs one town at a time (``batch.jobs.run_job``) set it, never a
stage.
"""
from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def cyclic_gc_paused(*, freeze: bool = False) -> Iterator[None]:
    """Disable the cyclic collector inside the block, and restore it as it was (nesting is fine).

    ``freeze``: move every object that outlives the block to the collector's permanent generation
    (:func:`gc.freeze`) before it resumes, for a block the process ends with (the command line's main
    command). The first collection after a pause would walk every object the block left alive, as
    young ones (Krems' default run: 204,000, 0.1-0.2 s): the process's modules and the model's
    memos, which live until it exits, and the little cyclic garbage made while the collector was off
    (Krems' whole default run: 802 objects). The freeze moves that garbage to the permanent
    generation too: it is never collected and its finalizers never run. That is harmless because
    the process exits next: the run's files are written and closed inside the block (``with``),
    and the memory goes back with the process. Collecting once before freezing would cost that very
    walk. Frozen objects are still freed by reference counting; only cycles among them stay.
    """
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if freeze:
            gc.freeze()
        if was_enabled:
            gc.enable()
