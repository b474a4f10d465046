"""The town as a source of patches: its copyable streets, their density, and the patches typical of it."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
import shapely.ops
from scipy.spatial import cKDTree

from osm_expand.model import City, Origin
from osm_expand.model.topology import segment_degree
from simplify.example import Example
from synth.patches.options import NOT_COPIED, PatchOptions


@dataclass(frozen=True)
class _Source:
    """The town's copyable streets: polylines, their class and level, an index, and the points where
    they met a street that is not copied (those ends are cut ends in a copy, not dead ends)."""

    lines: np.ndarray  #: shapely LineStrings
    highway: tuple[str, ...]
    level: np.ndarray
    tree: shapely.STRtree
    broken: cKDTree | None = None
    #: bridges and tunnels: copied as ordinary streets where, in the copy, they cross nothing
    layered: np.ndarray | None = None
    #: (J, 2) the town's junctions (degree ≥ 3): neighbourhoods are centred on them
    junctions: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


def _lengths(lines: list[np.ndarray]) -> np.ndarray:
    return np.array([float(np.hypot(*np.diff(xy, axis=0).T).sum()) for xy in lines])


def _line_xy(lines: np.ndarray) -> list[np.ndarray]:
    """Each line's vertices ((n, 2), as ``np.asarray(line.coords)`` gives them), read in one GEOS call:
    the measures take the town's streets as arrays, and reading 15,000 lines one by one took 0.2 s a
    district on a 10,000-street town."""
    if not len(lines):
        return []
    xy = shapely.get_coordinates(lines)
    return np.split(xy, np.cumsum(shapely.get_num_coordinates(lines))[:-1])


def _source(city: City, example: Example | None, everything: bool = False) -> _Source:
    """The town's streets that may be copied (``everything``: all its streets, as the fidelity measures
    them), with the Gravelius level of the example street holding each way (all one level without an
    ``example``: the neighbourhoods' draw reads no level)."""
    level_of: dict[int, int] = {}
    for s in example.network.streets if example is not None else ():
        for osm_id in s.osm_ids:
            level_of[osm_id] = min(level_of.get(osm_id, s.hierarchy), s.hierarchy)
    deepest = max(level_of.values(), default=0) + 1
    net = city.network
    copied = [s.origin == Origin.SOURCE and (everything or s.highway not in NOT_COPIED) for s in net.streets]
    keep = [s for s, c in zip(net.streets, copied) if c]
    lines = net.street_lines()[np.asarray(copied, dtype=bool)]
    level = np.array([min((level_of.get(i, deepest) for i in s.osm_ids), default=deepest) for s in keep])
    left_out = {n for s, c in zip(net.streets, copied) if not c for n in s.nodes}
    broken = sorted({n for s in keep for n in s.nodes} & left_out)
    junctions = net.xy[segment_degree(keep, len(net.xy)) >= 3]
    return _Source(lines=lines, highway=tuple(s.highway for s in keep), level=level, tree=shapely.STRtree(lines),
                   broken=cKDTree(net.xy[broken]) if broken else None,
                   layered=np.array([s.bridge or s.tunnel or s.layer != 0 for s in keep], dtype=bool),
                   junctions=junctions)


def _street_points(source: _Source, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points on the town's streets, drawn uniformly by length."""
    lengths = shapely.length(source.lines)
    cum = np.cumsum(lengths)
    at = rng.uniform(0.0, cum[-1], n)
    k = np.searchsorted(cum, at, side="right").clip(max=len(cum) - 1)
    pts = shapely.line_interpolate_point(source.lines[k], at - (cum[k] - lengths[k]))
    return shapely.get_coordinates(pts)


def _density(source: _Source, centres: np.ndarray, radius: float) -> np.ndarray:
    """Street length per m² in discs around ``centres``."""
    discs = shapely.buffer(shapely.points(centres), radius)
    return _lengths_in(source, discs) / (np.pi * radius ** 2)


def _lengths_in(source: _Source, discs: np.ndarray) -> np.ndarray:
    """The length of the source's streets inside each of ``discs`` (m), each summed in the tree's order.

    Only the streets that cross a disc's edge are clipped; a simple one
    wholly inside counts its own length, which is what clipping it gives, one
    that misses it 0.0
    (the overlay of every street was most of a disc's time). A street that
    crosses itself is clipped as before: GEOS splits it at the crossing and
    sums the parts in another order (1 ulp apart on Andorra's loops).
    All the discs are queried, tested and clipped in one GEOS call each
    (one disc at a time was 16 % of Campo Grande's district growth); each
    disc's lengths are still summed alone, in the order the tree gives them.
    """
    discs = np.asarray(discs, dtype=object)
    which, hit = source.tree.query(discs)
    lines, around = source.lines[hit], discs[which]
    shapely.prepare(discs)
    inside = shapely.contains_properly(around, lines) & shapely.is_simple(lines)
    lengths = shapely.length(lines)
    # a street whose box meets the disc's but which misses the disc adds the 0.0 its clip gave, unclipped
    cross = ~inside & shapely.intersects(around, lines)
    lengths[~inside & ~cross] = 0.0
    lengths[cross] = shapely.length(shapely.intersection(lines[cross], around[cross]))
    bounds = np.searchsorted(which, np.arange(len(discs) + 1))
    return np.array([float(lengths[a:b].sum()) for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist())])


def _neighbourhood_points(source: _Source, n: int, radius: float, rng: np.random.Generator) -> np.ndarray:
    """Centres of the town's *neighbourhoods*: ``2n`` junctions drawn at random, the denser half of them
    by junctions within ``radius`` kept (the fidelity yardstick's rule: on an extract that is mostly
    countryside, a random point of its streets is a country road, a dense junction is the town).
    Streets points by length when the town has too few junctions."""
    junctions = source.junctions
    if len(junctions) < 8:
        return _street_points(source, n, rng)
    drawn = junctions[rng.choice(len(junctions), size=min(2 * n, len(junctions)), replace=len(junctions) < 2 * n)]
    count = np.array([len(hit) for hit in cKDTree(junctions).query_ball_point(drawn, radius)])
    order = np.argsort(-count, kind="stable")
    return drawn[order[:max(len(drawn) // 2, 1)]]


#: What makes a patch typical of its town (measured on each candidate patch, in this order).
TYPICAL = ("curvature", "circuity", "edge_length", "dead_end_share", "three_way_share")


def _candidate_patches(source: _Source, size: float, opts: PatchOptions, rng: np.random.Generator,
                       measure: Callable | None = None) -> np.ndarray:
    """Patch centres on the town's streets, most typical of the town first.

    Candidates are discs around the town's neighbourhoods' junctions
    (:func:`_neighbourhood_points`) whose street density is within
    ``density_band`` of the median candidate's (the default keeps the denser
    side only: :class:`PatchOptions`). Each is
    measured (:data:`TYPICAL`: the median of a distribution, or a scalar) and
    ranked by its distance to the median candidate, each measure scaled by
    the candidates' spread, so the district is made of the town's ordinary
    fabric rather than its oddities. A candidate within one patch of a better
    one goes to the back, so neighbouring cells differ.
    """
    centres = _neighbourhood_points(source, opts.candidates, size / 2, rng)
    local = _density(source, centres, size / 2)
    median = float(np.median(local))
    lo, hi = opts.density_band[0] * median, opts.density_band[1] * median
    good = np.flatnonzero((local >= lo) & (local <= hi))
    if not len(good):
        good = np.argsort(np.abs(local - median))[:1]
    if measure is None or len(good) <= 1:
        return _spread(centres, good, size)
    in_window = measure(_line_xy(source.lines))
    measured = [in_window(shapely.Point(centres[i]).buffer(size / 2)) for i in good.tolist()]
    values = np.array([[_level(m, name) for name in TYPICAL] for m in measured])
    centre = np.nanmedian(values, axis=0)
    spread = np.nanpercentile(values, 75, axis=0) - np.nanpercentile(values, 25, axis=0)
    z = np.nan_to_num(np.abs(values - centre) / np.where(spread > 0, spread, 1.0), nan=3.0)
    good = good[np.argsort(np.sqrt((z ** 2).sum(axis=1)), kind="stable")]
    return _spread(centres, good, size)


def _spread(centres: np.ndarray, good: np.ndarray, size: float) -> np.ndarray:
    """``centres[good]`` in ``good``'s order, each within one patch of an earlier one sent to the back."""
    first: list[int] = []
    later: list[int] = []
    for i in good.tolist():
        (later if any(np.hypot(*(centres[i] - centres[j])) < size for j in first) else first).append(i)
    return centres[first + later]


def _level(measures, name: str) -> float:
    value = measures.value(name)
    if np.ndim(value):
        return float(np.median(value)) if len(value) else float("nan")
    return float(value)
