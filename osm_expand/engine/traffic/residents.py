"""Residents per street segment, the trip model's sources and attractions: from lots, or from blocks
before any lot is known (002 §3.2)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from osm_expand.engine.traffic.trip_options import TripOptions
from osm_expand.errors import InputError

__all__ = ["residents_from_blocks", "residents_from_lots"]


# --------------------------------------------------------------------------- residents

def residents_from_lots(lot_residents: NDArray[np.floating], lot_segment: NDArray[np.integer],
                        n_segments: int) -> NDArray[np.float64]:
    """``street[i].residents = Σ lot[j].residents`` over the lots facing it (002 §3.2).

    Parameters
    ----------
    lot_residents : (L,) float
        People per lot over 24 hours (residents, workers, visitors).
    lot_segment : (L,) int
        The segment each lot has its access from (-1: none, ignored).
    n_segments : int

    Returns
    -------
    (n_segments,) float64
    """
    res = np.asarray(lot_residents, dtype=np.float64).reshape(-1)
    seg = np.asarray(lot_segment, dtype=np.int64).reshape(-1)
    if len(res) != len(seg):
        raise InputError(f"trips: {len(res)} lot residents but {len(seg)} lot segments")
    ok = seg >= 0
    if ok.any() and seg[ok].max() >= n_segments:
        raise InputError(f"trips: a lot faces segment {seg[ok].max()}, beyond 0..{n_segments - 1}")
    return np.bincount(seg[ok], weights=res[ok], minlength=n_segments).astype(np.float64)


def residents_from_blocks(block_area: NDArray[np.floating],
                          block_segments: Sequence[Sequence[int]] | Sequence[NDArray[np.integer]],
                          segment_length: NDArray[np.floating], *,
                          options: TripOptions = TripOptions()) -> NDArray[np.float64]:  # noqa: B008 (frozen)
    """Residents per segment before lots exist: block area × ``density``, shared by side length.

    Parameters
    ----------
    block_area : (B,) float
        Block areas, m² (built-up blocks only; leave out water and fields).
    block_segments : sequence of B int sequences
        The segments bounding each block.
    segment_length : (E,) float
        Segment lengths, m.
    options : TripOptions
        ``density`` (people per m²).

    Returns
    -------
    (E,) float64
        A segment between two blocks collects from both.
    """
    area = np.asarray(block_area, dtype=np.float64).reshape(-1)
    seglen = np.asarray(segment_length, dtype=np.float64).reshape(-1)
    if len(area) != len(block_segments):
        raise InputError(f"trips: {len(area)} block areas but {len(block_segments)} segment lists")
    sizes = np.array([len(s) for s in block_segments], dtype=np.int64)
    if sizes.sum() == 0:
        return np.zeros(len(seglen))
    segs = np.concatenate([np.asarray(s, dtype=np.int64).reshape(-1) for s in block_segments])
    if segs.min() < 0 or segs.max() >= len(seglen):
        raise InputError(f"trips: a block lists a segment outside 0..{len(seglen) - 1}")
    block = np.repeat(np.arange(len(area)), sizes)
    side = seglen[segs]
    perimeter = np.bincount(block, weights=side, minlength=len(area))
    share = side / np.where(perimeter[block] > 0, perimeter[block], 1.0)
    share = np.where(perimeter[block] > 0, share, 1.0 / np.maximum(sizes[block], 1))
    people = area[block] * options.density * share
    return np.bincount(segs, weights=people, minlength=len(seglen)).astype(np.float64)
