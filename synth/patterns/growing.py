"""Growing streets from starts: a Default street drawn, its proposals tried, the first valid one built, and
000 §4.2.3's bridges by rays."""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from osm_expand.errors import InputError
from synth.patterns.options import AngleSpace, LengthMode, PatternOptions, PdfKind, Proposal
from synth.patterns.proposals import (
    GrowthStep,
    Start,
    StartPoints,
    StreetProposal,
    _Candidates,
    _Context,
    _direction,
    _Log,
    _min_angle_between,
    _propose,
    _resolve,
)
from synth.patterns.rules import _Areas, _check
from synth.patterns.sets import ORGANIC
from synth.street_graph import StreetGraph

# --------------------------------------------------------------------------- drawing a Default street

class _Sampler:
    """Draws (relative angle, length) pairs from a pattern's PDFs."""

    def __init__(self, options: PatternOptions):
        self.o = options
        ang = np.array([a for a, _ in options.angle_pdf]) % 360.0
        w = np.array([w for _, w in options.angle_pdf])
        self.kind = options.angle_pdf_kind
        if self.kind is PdfKind.CONTINUOUS:
            order = np.argsort(ang, kind="stable")
            ang, w = ang[order], w[order]
            nxt_a = np.append(ang[1:], ang[0] + 360.0)
            nxt_w = np.append(w[1:], w[0])
            self.lo, self.width, self.w0, self.w1 = ang, nxt_a - ang, w, nxt_w
            area = 0.5 * (w + nxt_w) * self.width
            self.cum = np.cumsum(area) / area.sum()
        else:
            self.peaks = ang
            self.cum = np.cumsum(w) / w.sum()
        if options.length_from_orientation:
            la = np.array([a for a, _ in options.length_from_orientation]) % 360.0
            lv = np.array([v for _, v in options.length_from_orientation])
            order = np.argsort(la, kind="stable")
            la, lv = la[order], lv[order]
            self.len_angle = np.concatenate([la - 360.0, la, la + 360.0])
            self.len_value = np.concatenate([lv, lv, lv])

    def angle(self, rng: np.random.Generator) -> float:
        """A relative angle in degrees."""
        k = min(int(np.searchsorted(self.cum, rng.random(), side="right")), len(self.cum) - 1)
        if self.kind is PdfKind.CONTINUOUS:
            w0, w1, width = self.w0[k], self.w1[k], self.width[k]
            u = rng.random()
            if abs(w1 - w0) < 1e-12 * max(w0, w1, 1e-12):
                x = u * width
            else:  # inverse CDF of a density linear from w0 to w1 over [0, width]
                x = width * (-w0 + math.sqrt(w0 * w0 + (w1 * w1 - w0 * w0) * u)) / (w1 - w0)
            return float(self.lo[k] + x)
        a = float(self.peaks[k])
        if self.kind is PdfKind.GAUSSIAN and self.o.angle_spread_deg > 0:
            a += self.o.angle_spread_deg * float(rng.standard_normal())
        return a

    def length(self, rel_angle_deg: float, rng: np.random.Generator) -> float:
        o = self.o
        if o.length_mode is LengthMode.ORIENTATION:
            base = float(np.interp(rel_angle_deg % 360.0, self.len_angle, self.len_value))
            value = base * (1.0 + o.length_jitter * float(rng.standard_normal())) if o.length_jitter else base
            return float(np.clip(value, o.min_length_m, o.max_length_m))
        for _ in range(8):  # truncated Gaussian by rejection, then clipped
            value = o.length_mean_m + o.length_sd_m * float(rng.standard_normal())
            if o.min_length_m <= value <= o.max_length_m:
                return value
        return float(np.clip(value, o.min_length_m, o.max_length_m))


def _reference_angle(ctx: _Context, options: PatternOptions, centre: NDArray[np.float64] | None) -> float:
    """World direction (rad) that relative angle 0 points to."""
    off = math.radians(options.angle_offset_deg)
    if options.angle_space is AngleSpace.CROSSING and ctx.first_dir is not None:
        return ctx.first_dir + off
    if options.angle_space is AngleSpace.CENTRE and centre is not None:
        ray = _direction(ctx.xy - centre)
        if ray is not None:
            return ray + off
    return off


def _draw_default(ctx: _Context, sampler: _Sampler, options: PatternOptions, centre: NDArray[np.float64] | None,
                  rng: np.random.Generator) -> tuple[float, float]:
    """World angle (rad) and length (m) of a Default street from the start."""
    rel = sampler.angle(rng)
    length = sampler.length(rel, rng)
    theta = _reference_angle(ctx, options, centre) + math.radians(rel)
    if options.angle_space is AngleSpace.CENTRE and options.ring_chords and centre is not None:
        radius = math.hypot(*(ctx.xy - centre))
        if radius > 0:
            theta += math.asin(min(1.0, length / (2 * radius))) * math.sin(math.radians(rel))
    return theta, length


# --------------------------------------------------------------------------- bridges by rays (000 §4.2.3)

def _ray_bridge(ctx: _Context, options: PatternOptions, areas: _Areas,
                rng: np.random.Generator) -> StreetProposal | None:
    """000 §4.2.3: from a crossing near water, the ray that crosses water in the shortest span."""
    if areas.water is None or options.bridge_rays == 0 or not options.bridges_enabled:
        return None
    p = ctx.xy
    if not shapely.dwithin(areas.water, shapely.points(p), options.bridge_search_radius_m):
        return None
    step = options.bridge_sample_step_m
    n = int(options.max_bridge_length_m // step)
    fan = 2 * math.pi / options.bridge_rays
    theta = (rng.random() + np.arange(options.bridge_rays)) * fan
    dist = step * np.arange(1, n + 1)
    x = p[0] + np.cos(theta)[:, None] * dist
    y = p[1] + np.sin(theta)[:, None] * dist
    wet = shapely.intersects_xy(areas.water, x, y)
    best, best_len = None, math.inf
    for r in range(options.bridge_rays):
        w = np.flatnonzero(wet[r])
        if len(w) == 0:
            continue
        dry = np.flatnonzero(~wet[r, w[0]:])
        if len(dry) == 0:
            continue
        j = w[0] + dry[0]
        if dist[j] < best_len:
            best, best_len = (x[r, j], y[r, j]), dist[j]
    return None if best is None else StreetProposal(Proposal.BRIDGE, (float(best[0]), float(best[1])))


# --------------------------------------------------------------------------- growing

def grow_streets(graph: StreetGraph, starts: StartPoints | ArrayLike | Sequence[Start], *,
                 options: PatternOptions = ORGANIC, rng: np.random.Generator,
                 water: shapely.Geometry | None = None, forbidden: shapely.Geometry | None = None,
                 centre: ArrayLike | None = None, time: float = 0.0) -> GrowthStep:
    """Grow streets from each start with one street pattern (000 §4.2.6), updating ``graph`` in place.

    For each start in order: up to ``attempts_per_start`` times, draw a
    Default street (angle from ``angle_pdf`` in the pattern's frame, length
    from the length PDF or the orientation), make the Snap, Shorten, Extend
    and Default proposals and build the first valid one (rules a–g, water,
    bridges); stop after ``streets_per_start`` streets. A crossing within
    ``bridge_search_radius_m`` of water that has not made its bridge attempt
    first tries 000 §4.2.3's ray bridge. A start on a segment is split only
    when a street grows from it. Every start that was a crossing, or became
    one, is marked in ``graph.spawned`` (grown or exhausted: 002 §3.1 marks
    a node finished "if the expansion fails multiple times").

    Parameters
    ----------
    graph : StreetGraph
        Modified in place: nodes and segments added, segments split, the
        ``spawned`` and ``bridge_tried`` marks set.
    starts : int array of shape (S,), sequence of Start, or StartPoints
        Node ids, or objects with ``node`` (-1 for a point on a segment),
        ``segment`` and ``xy`` arrays (e.g. the ranked candidates of
        :func:`osm_expand.engine.growth.nuclei.candidate_points`). A segment start
        whose segment was split earlier in the call is found again by position;
        segment starts are skipped when the pattern's ``segment_starts`` is False.
    options : PatternOptions
        The era's street pattern.
    rng : numpy.random.Generator
        The only source of randomness; same state, same result.
    water, forbidden : shapely geometry, optional
        Water (streets may cross it only as bridges, never end in it) and
        forbidden areas (streets may not touch them), in metres. Prepared in place.
    centre : array_like, shape (2,), optional
        Pattern centre (m) for ``angle_space = "centre"`` (002's radial: the
        nearest city centre); required then.
    time : float
        Creation time recorded on the new segments (the current year).

    Returns
    -------
    GrowthStep
        What was added, with ids into ``graph``.
    """
    if options.angle_space is AngleSpace.CENTRE and centre is None:
        raise InputError("grow_streets: angle_space 'centre' needs a centre point")
    centre_xy = None if centre is None else np.asarray(centre, dtype=np.float64).reshape(2)
    start_list = _as_starts(graph, starts)
    sampler = _Sampler(options)
    areas = _Areas(water, forbidden)
    log = _Log()
    grown = np.zeros(len(start_list), dtype=bool)
    start_node = np.full(len(start_list), -1, dtype=np.int64)
    for i, raw in enumerate(start_list):
        if raw.node < 0 and not options.segment_starts:
            continue
        start = _resolve(graph, raw)
        if start is None:
            continue
        made, node = _grow_from(graph, start, i, options, sampler, areas, centre_xy, rng, time, log)
        grown[i] = made > 0
        if node < 0:
            log.failed.append(start.xy)
        start_node[i] = node
        if node >= 0:
            graph.spawned[node] = True
    return GrowthStep(
        new_nodes=np.asarray(log.nodes, dtype=np.int64),
        new_segments=np.asarray(log.segments, dtype=np.int64),
        proposal=np.asarray(log.kinds, dtype=np.str_),
        start_index=np.asarray(log.starts, dtype=np.int64),
        bridges=np.asarray(log.bridges, dtype=np.int64),
        split_segment=np.asarray([s[0] for s in log.splits], dtype=np.int64),
        split_node=np.asarray([s[1] for s in log.splits], dtype=np.int64),
        split_new_segment=np.asarray([s[2] for s in log.splits], dtype=np.int64),
        failed_xy=np.asarray(log.failed, dtype=np.float64).reshape(-1, 2),
        grown=grown, start_node=start_node,
    )


def _as_starts(graph: StreetGraph, starts: Any) -> list[Start]:
    if isinstance(starts, (list, tuple)) and starts and isinstance(starts[0], Start):
        return list(starts)
    if hasattr(starts, "node") and hasattr(starts, "segment") and hasattr(starts, "xy"):
        node = np.asarray(starts.node, dtype=np.int64)
        seg = np.asarray(starts.segment, dtype=np.int64)
        xy = np.asarray(starts.xy, dtype=np.float64).reshape(-1, 2)
        return [Start.at_node(graph, int(n)) if n >= 0 else Start.on_segment(int(s), p)
                for n, s, p in zip(node.tolist(), seg.tolist(), xy)]
    ids = np.asarray(starts, dtype=np.int64).reshape(-1)
    if len(ids) and (ids.min() < 0 or ids.max() >= graph.n_nodes):
        raise InputError(f"grow_streets: start node ids must lie in 0..{graph.n_nodes - 1}")
    return [Start.at_node(graph, int(n)) for n in ids.tolist()]


def _grow_from(graph: StreetGraph, start: Start, index: int, options: PatternOptions, sampler: _Sampler,
               areas: _Areas, centre: NDArray[np.float64] | None, rng: np.random.Generator, time: float,
               log: _Log) -> tuple[int, int]:
    """Grow up to streets_per_start streets from one start; returns how many, and its crossing (or -1)."""
    made = 0
    ctx = _Context(graph, start)
    if ctx.degree >= options.max_degree:
        return 0, start.node
    if start.node >= 0 and not ctx.bridge_tried:
        bridge = _ray_bridge(ctx, options, areas, rng)
        if bridge is not None:
            cand = _Candidates.gather(graph, ctx.xy, np.asarray(bridge.end_xy), options)
            verdict = _check(graph, ctx, bridge, cand, options, areas)
            graph.bridge_tried[start.node] = ctx.bridge_tried = True
            if verdict.rule is None:
                start = _build(graph, start, bridge, True, index, time, log, areas)
                made += 1
                ctx = _Context(graph, start)
    for _ in range(options.attempts_per_start):
        if made >= options.streets_per_start or ctx.degree >= options.max_degree:
            break
        theta, length = _draw_default(ctx, sampler, options, centre, rng)
        if _hopeless(ctx, theta, length, options):
            continue
        end = ctx.xy + length * np.array([math.cos(theta), math.sin(theta)])
        cand = _Candidates.gather(graph, ctx.xy, end, options)
        for prop in _propose(graph, ctx, cand, theta, length, options):
            verdict = _check(graph, ctx, prop, cand, options, areas)
            if verdict.bridge_tested:  # the start's one bridge attempt is used, built or not
                ctx.bridge_tried = True
                if start.node >= 0:
                    graph.bridge_tried[start.node] = True
            if verdict.rule is None:
                start = _build(graph, start, prop, verdict.bridge, index, time, log, areas)
                if verdict.bridge or ctx.bridge_tried:
                    graph.bridge_tried[start.node] = True
                made += 1
                ctx = _Context(graph, start)
                break
    return made, start.node


def _hopeless(ctx: _Context, theta: float, length: float, options: PatternOptions) -> bool:
    """No proposal of this Default street can pass rule b at the start (a shortcut, not a rule).

    Shorten, Extend and Default share its direction; a Snap end lies within
    the snap radius of its end, so its direction differs by at most
    asin(snap_radius / length) (any direction when the street is shorter).
    """
    gap = _min_angle_between(theta, ctx.incident_dirs)
    min_angle = math.radians(options.min_angle_deg)
    if gap >= min_angle:
        return False
    if not options.snap_enabled or options.snap_radius_m >= length:
        return not options.snap_enabled
    return gap + math.asin(options.snap_radius_m / length) < min_angle


def _build(graph: StreetGraph, start: Start, prop: StreetProposal, bridge: bool, index: int, time: float,
           log: _Log, areas: _Areas) -> Start:
    """Add the proposal's street (splitting where it starts or ends on a segment); returns the start as a crossing."""
    c = start.node
    if c < 0:
        c = _split(graph, start.segment, np.asarray(start.xy), log, areas)
    end_xy = np.asarray(prop.end_xy, dtype=np.float64)
    if prop.end_node >= 0:
        e = prop.end_node
    elif prop.end_segment >= 0:
        seg = prop.end_segment
        if graph.segment_at(end_xy) != seg:  # the start split moved it
            seg = graph.segment_at(end_xy)
        e = _split(graph, seg, end_xy, log, areas)
    else:
        e = graph.add_node(end_xy)
        log.nodes.append(e)
    s = graph.add_segment(c, e, created=time, bridge=bridge)
    log.segments.append(s)
    log.kinds.append(str(prop.kind))
    log.starts.append(index)
    if bridge:
        log.bridges.append(s)
        graph.bridge_tried[e] = True
    return Start.at_node(graph, c)


def _split(graph: StreetGraph, segment: int, point: NDArray[np.float64], log: _Log, areas: _Areas) -> int:
    """Split a segment for a new street's end; a split bridge stays a bridge only where it crosses water."""
    node = graph.split(segment, point)
    half = graph.n_segments - 1
    log.nodes.append(node)
    log.splits.append((segment, node, half))
    if graph.bridge[segment] and areas.water is not None:
        for k in (segment, half):
            a, b = graph.segment_ends([k])
            graph.bridge[k] = areas.crosses_water(a[0], b[0])
    return node
