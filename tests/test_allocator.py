"""The main command keeps the memory it frees for its next arrays (:mod:`osm_expand.allocator`)."""
from __future__ import annotations

import subprocess
import sys

import pytest

_FAULTS = """
import resource, sys
import numpy as np
from osm_expand.allocator import keep_freed_memory
kept = keep_freed_memory() if sys.argv[1] == "keep" else None
faults = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_minflt
later = 0
for i, n in enumerate((3_000_000, 1_000_000, 3_000_000, 2_000_000)):  # 24, 8, 24, 16 MB of float64
    before = faults()
    a = np.ones(n)
    later += (faults() - before) if i else 0
    del a
print(kept, later)
"""


def _later_faults(how: str) -> tuple[str, int]:
    out = subprocess.run([sys.executable, "-c", _FAULTS, how], capture_output=True, text=True, check=True).stdout
    kept, later = out.split()
    return kept, int(later)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_arrays_freed_are_reused_without_faulting_their_pages_in_again():
    """Issue 22: 6–9 s of Campo Grande's default run was system time, the kernel faulting in (and
    zeroing) the pages of arrays of tens of megabytes made and dropped one after another. With
    the heap kept, an array the size of one freed before takes its memory without a page fault;
    by default glibc handed the first back and faulted in the next two (hundreds of faults)."""
    kept, later = _later_faults("keep")
    if kept != "True":
        pytest.skip("no glibc mallopt here")
    assert later < 50
    assert _later_faults("default")[1] > later

