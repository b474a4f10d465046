"""glibc's allocator told to keep the memory the engine frees for its next arrays (process state).

A road year builds and drops arrays of tens to hundreds of megabytes one after another (a
search window's matrices, the heading-expanded graphs, their Dijkstra's distances). By default
glibc gives every block above its mmap threshold (at most 32 MiB) back to the kernel on ``free``
and hands the top of its heap back once more than twice that lies free there, so the next array
of that size is faulted in afresh, page by page, each page zeroed by the kernel: 6–9 s of Campo
Grande's default run was system time. With the heap kept (no trim, a generous top pad) and the
mmap threshold fixed at its largest, the blocks a year frees are reused instead; only the arrays
above 32 MiB are still mapped and unmapped.

It is process state: only the command line sets it (like :mod:`osm_expand.gcpause`), never a stage.
Outputs do not depend on it. Elsewhere than on glibc (no ``mallopt``) it does nothing.
"""
from __future__ import annotations

import sys

#: mallopt's parameters (glibc's malloc.h)
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3

#: bytes: the heap is never trimmed below this much free memory at its top (2 GiB: in effect never;
#: the peak resident size is set by what is live at once, which the heap's reuse does not raise)
TRIM_THRESHOLD = 2**31 - 1
#: bytes the heap grows by beyond what a request needs (256 MiB: a year's arrays fit without a new
#: ``brk`` each; untouched, the pad is not resident)
TOP_PAD = 256 * 2**20
#: bytes from which a block is mapped on its own and unmapped when freed: glibc's largest (32 MiB on
#: 64-bit), fixed (the default starts at 128 KiB and climbs only as blocks are freed)
MMAP_THRESHOLD = 32 * 2**20


def keep_freed_memory() -> bool:
    """Set the three parameters above with glibc's ``mallopt``; whether it took them all (False
    where there is no glibc: nothing changes)."""
    if not sys.platform.startswith("linux"):
        return False
    import ctypes  # 7 ms: only for the command that sets it

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    settings = ((_M_TRIM_THRESHOLD, TRIM_THRESHOLD), (_M_TOP_PAD, TOP_PAD), (_M_MMAP_THRESHOLD, MMAP_THRESHOLD))
    return all([mallopt(param, value) == 1 for param, value in settings])
