"""Streets follow their traffic (002 §2, §3.2): a planned street is built when its traffic reaches
``build_threshold``, and a built street's width follows its traffic after ``width_delay`` years."""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from osm_expand.engine.traffic.trip_options import TripOptions
from osm_expand.errors import InputError

__all__ = ["update_status", "update_widths", "width_for_traffic"]


# --------------------------------------------------------------------------- streets: status and width

def update_status(built: NDArray[np.bool_], traffic: NDArray[np.floating], built_year: NDArray[np.integer], *,
                  year: int, options: TripOptions = TripOptions()) -> tuple[NDArray[np.bool_], NDArray[np.int64]]:  # noqa: B008 (frozen)
    """Planned streets with enough traffic are built (002 §2, §3.2).

    Parameters
    ----------
    built : (E,) bool
        True for built streets, False for planned ones.
    traffic : (E,) float
        People a day (:attr:`TripState.traffic`).
    built_year : (E,) int
        Year each was built (any value for planned streets).
    year : int
        The current year.
    options : TripOptions
        ``build_threshold``.

    Returns
    -------
    built : (E,) bool
    built_year : (E,) int64
        ``year`` for the streets built now.
    """
    b = np.asarray(built, dtype=bool).reshape(-1)
    t = np.asarray(traffic, dtype=np.float64).reshape(-1)
    y = np.asarray(built_year, dtype=np.int64).reshape(-1)
    if not len(b) == len(t) == len(y):
        raise InputError(f"trips: {len(b)} status flags, {len(t)} traffic values, {len(y)} years")
    now = ~b & (t >= options.build_threshold)
    return b | now, np.where(now, int(year), y)


def width_for_traffic(traffic: NDArray[np.floating], major: NDArray[np.bool_] | None = None, *,
                      options: TripOptions = TripOptions()) -> NDArray[np.float64]:  # noqa: B008 (frozen)
    """Street width the traffic asks for: lanes · lane_width + 2 · sidewalk_width.

    ``lanes = ceil(traffic / lane_capacity)``, clipped to
    [min_lanes (major_min_lanes for major roads), max_lanes].

    Parameters
    ----------
    traffic : (E,) float
        People a day.
    major : (E,) bool, optional
        Major roads (at least ``major_min_lanes``).
    options : TripOptions

    Returns
    -------
    (E,) float64
        Metres.
    """
    t = np.asarray(traffic, dtype=np.float64).reshape(-1)
    low = np.full(len(t), options.min_lanes)
    if major is not None:
        low = np.where(np.asarray(major, dtype=bool).reshape(-1), options.major_min_lanes, low)
    lanes = np.clip(np.ceil(np.maximum(t, 0.0) / options.lane_capacity), low, options.max_lanes)
    return lanes * options.lane_width + 2 * options.sidewalk_width


def update_widths(width: NDArray[np.floating], traffic: NDArray[np.floating], built: NDArray[np.bool_],
                  built_year: NDArray[np.integer], pending_since: NDArray[np.integer], *, year: int,
                  major: NDArray[np.bool_] | None = None,
                  options: TripOptions = TripOptions()) -> tuple[NDArray[np.float64], NDArray[np.int64]]:  # noqa: B008 (frozen)
    """Widths follow traffic after ``width_delay`` years (002 §3.2).

    - Planned streets take the width their traffic asks for at once (the plan).
    - A street built this year gets a *temporary* width from its traffic
      now, and its final width ``width_delay`` years later (002).
    - A built street whose wanted width (only wider, unless ``shrink``)
      differs from its width starts a wait; if it still differs after
      ``width_delay`` years it takes the then wanted width. A wait ends
      early, unchanged, when the need goes away.

    Parameters
    ----------
    width : (E,) float
        Current widths, m.
    traffic : (E,) float
        People a day.
    built : (E,) bool
        Built (True) or planned.
    built_year : (E,) int
        Year each street was built. Give the real town's streets a year
        before the first simulated one: a street "built this year" gets a
        temporary width from its traffic, which would overwrite a mapped width.
    pending_since : (E,) int
        Year a wait started, -1 for none (start with all -1).
    year : int
        The current year.
    major : (E,) bool, optional
        Major roads (see :func:`width_for_traffic`).
    options : TripOptions

    Returns
    -------
    width : (E,) float64
    pending_since : (E,) int64
    """
    w = np.asarray(width, dtype=np.float64).reshape(-1)
    b = np.asarray(built, dtype=bool).reshape(-1)
    by = np.asarray(built_year, dtype=np.int64).reshape(-1)
    pend = np.asarray(pending_since, dtype=np.int64).reshape(-1).copy()
    t = np.asarray(traffic, dtype=np.float64).reshape(-1)
    if not len(w) == len(b) == len(by) == len(pend) == len(t):
        raise InputError("trips: width, traffic, built, built_year and pending_since differ in length")
    target = width_for_traffic(t, major, options=options)
    want = target if options.shrink else np.maximum(target, w)
    out = w.copy()
    planned = ~b
    out[planned] = target[planned]
    pend[planned] = -1
    fresh = b & (by == year)
    out[fresh] = target[fresh]
    pend[fresh] = year
    old = b & ~fresh
    differs = old & ~np.isclose(want, w)
    from_build = old & (pend >= 0) & (by == pend)  # the final width after the temporary one
    pend[old & ~differs & ~from_build] = -1
    pend[differs & (pend < 0)] = year
    due = old & (pend >= 0) & (year - pend >= options.width_delay)
    out[due] = want[due]
    pend[due] = -1
    return out, pend
