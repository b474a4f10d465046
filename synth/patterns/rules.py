"""The rules a proposal must pass (000 §4.2.6, a–g), with water, forbidden areas and bridges."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.model.geometry import closest_on_segments
from synth.patterns.options import PatternOptions, Rule
from synth.patterns.proposals import (
    ON_TOLERANCE,
    Start,
    StreetProposal,
    _angles,
    _Candidates,
    _Context,
    _min_angle_between,
)
from synth.patterns.sets import ORGANIC
from synth.segment_index import _intersects
from synth.street_graph import StreetGraph

# --------------------------------------------------------------------------- the rules

@dataclass
class _Verdict:
    rule: Rule | None
    bridge: bool = False        # the proposal crosses water
    bridge_tested: bool = False  # it reached the bridge tests: the start's attempt is used


class _Areas:
    """Water and forbidden areas, prepared once per call."""

    def __init__(self, water: shapely.Geometry | None, forbidden: shapely.Geometry | None):
        self.water = _prepared(water)
        self.forbidden = _prepared(forbidden)

    def in_water(self, p: NDArray[np.float64]) -> bool:
        return self.water is not None and bool(shapely.intersects_xy(self.water, p[0], p[1]))

    def crosses_water(self, p: NDArray[np.float64], q: NDArray[np.float64]) -> bool:
        return self.water is not None and bool(shapely.intersects(self.water, shapely.linestrings([p, q])))

    def touches_forbidden(self, p: NDArray[np.float64], q: NDArray[np.float64]) -> bool:
        return self.forbidden is not None and bool(shapely.intersects(self.forbidden, shapely.linestrings([p, q])))


def _prepared(geom: shapely.Geometry | None) -> shapely.Geometry | None:
    if geom is None or shapely.is_empty(geom):
        return None
    shapely.prepare(geom)
    return geom


def check_proposal(graph: StreetGraph, start: Start, proposal: StreetProposal, *,
                   options: PatternOptions = ORGANIC, water: shapely.Geometry | None = None,
                   forbidden: shapely.Geometry | None = None) -> Rule | None:
    """The first rule a proposal breaks, or None if it is valid (000 §4.2.6 a–g, water, bridges).

    Rules are tested in this order: spacing of a start that splits a
    segment (e), length (c), degree (g), angle at both ends (b), triangle
    (f), spacing of a new end crossing (e), crossing (a), street distance
    (d), forbidden area, water (ending in it; crossing it with bridges off),
    then for a bridge: the start's one attempt, ``max_bridge_length_m``,
    spacing to other bridges. A street longer than ``max_length_m`` but no
    longer than ``max_bridge_length_m`` passes c only if it is a bridge.

    Parameters
    ----------
    graph : StreetGraph
    start : Start
    proposal : StreetProposal
    options : PatternOptions
    water, forbidden : shapely geometry, optional
        Areas (m) a street may not end in / may not touch. Prepared in place.

    Returns
    -------
    Rule or None
    """
    ctx = _Context(graph, start)
    cand = _Candidates.gather(graph, ctx.xy, np.asarray(proposal.end_xy, dtype=np.float64), options)
    return _check(graph, ctx, proposal, cand, options, _Areas(water, forbidden)).rule


def _check(graph: StreetGraph, ctx: _Context, prop: StreetProposal, cand: _Candidates,
           options: PatternOptions, areas: _Areas) -> _Verdict:
    p = ctx.xy
    q = np.asarray(prop.end_xy, dtype=np.float64)
    v = q - p
    length = math.hypot(v[0], v[1])
    if ctx.node < 0 and cand.any_node_within(p, options.min_cc_distance_m):
        return _Verdict(Rule.CC_DISTANCE)
    # c) length (the upper bound waits for the water test when a bridge may be longer)
    longest = options.max_length_m
    if options.bridges_enabled:
        longest = max(longest, options.max_bridge_length_m)
    if length < options.min_length_m or length > longest:
        return _Verdict(Rule.LENGTH)
    # g) degree at both ends
    end_degree = graph.node_degree(prop.end_node) if prop.end_node >= 0 else (2 if prop.end_segment >= 0 else 0)
    if ctx.degree + 1 > options.max_degree or end_degree + 1 > options.max_degree:
        return _Verdict(Rule.DEGREE)
    # b) angle with every street sharing a crossing, at the start and at the end
    theta = math.atan2(v[1], v[0])
    min_angle = math.radians(options.min_angle_deg)
    if _min_angle_between(theta, ctx.incident_dirs) < min_angle:
        return _Verdict(Rule.ANGLE)
    end_nb = _end_neighbours(graph, prop)
    if len(end_nb) and _min_angle_between(theta + math.pi, _angles(graph.xy[end_nb] - q)) < min_angle:
        return _Verdict(Rule.ANGLE)
    # f) no triangle (nor a second street between the same crossings)
    if prop.end_node >= 0 and (prop.end_node in ctx.neighbours or set(ctx.neighbours) & set(end_nb.tolist())):
        return _Verdict(Rule.TRIANGLE)
    if prop.end_segment >= 0 and set(ctx.neighbours) & set(end_nb.tolist()):
        return _Verdict(Rule.TRIANGLE)
    # e) a new end crossing keeps its distance from existing crossings
    if prop.end_node < 0 and cand.any_node_within(q, options.min_cc_distance_m):
        return _Verdict(Rule.CC_DISTANCE)
    # a) and d) against the non-incident streets nearby
    excluded = list(ctx.excluded)
    if prop.end_node >= 0:
        excluded += graph.incident(prop.end_node)
    elif prop.end_segment >= 0:
        excluded.append(prop.end_segment)
    rule = _street_rules(p, q, cand, excluded, options.min_cs_distance_m)
    if rule is not None:
        return _Verdict(rule)
    # water and forbidden areas
    if areas.touches_forbidden(p, q):
        return _Verdict(Rule.FORBIDDEN)
    if areas.in_water(q):
        return _Verdict(Rule.WATER)
    if not areas.crosses_water(p, q):
        return _Verdict(Rule.LENGTH if length > options.max_length_m else None)
    if not options.bridges_enabled:
        return _Verdict(Rule.WATER, bridge=True)
    if ctx.bridge_tried:
        return _Verdict(Rule.BRIDGE_ATTEMPT, bridge=True)
    if length > options.max_bridge_length_m:
        return _Verdict(Rule.BRIDGE_LENGTH, bridge=True, bridge_tested=True)
    if _bridge_too_close(graph, p, q, options.min_bridge_spacing_m):
        return _Verdict(Rule.BRIDGE_SPACING, bridge=True, bridge_tested=True)
    return _Verdict(None, bridge=True, bridge_tested=True)


def _end_neighbours(graph: StreetGraph, prop: StreetProposal) -> NDArray[np.int64]:
    if prop.end_node >= 0:
        return np.asarray(graph.neighbours(prop.end_node), dtype=np.int64)
    if prop.end_segment >= 0:
        return graph.edges[prop.end_segment].copy()
    return np.zeros(0, dtype=np.int64)


def _street_rules(p: NDArray[np.float64], q: NDArray[np.float64], cand: _Candidates, excluded: list[int],
                  min_distance: float) -> Rule | None:
    """Rule a (no crossing of a non-incident street) and rule d (distance ≥ min_distance to one)."""
    if len(cand.ids) == 0:
        return None
    reach = min_distance + ON_TOLERANCE   # only segments whose box comes this near can cross or come close
    lo, hi = np.minimum(p, q) - reach, np.maximum(p, q) + reach
    keep = ((cand.lo[:, 0] <= hi[0]) & (cand.hi[:, 0] >= lo[0]) & (cand.lo[:, 1] <= hi[1])
            & (cand.hi[:, 1] >= lo[1]))
    for s in excluded:
        keep &= cand.ids != s
    a, b = cand.a[keep], cand.b[keep]
    if len(a) == 0:
        return None
    if _intersects(p, q, a, b).any():
        return Rule.CROSSING
    if min_distance > 0 and _segment_distance(p, q, a, b).min() < min_distance:
        return Rule.CS_DISTANCE
    return None


def _segment_distance(p: NDArray[np.float64], q: NDArray[np.float64], a: NDArray[np.float64],
                      b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (m) between segment p–q and each non-crossing segment a–b: the least end-to-segment distance."""
    ends = np.stack([p, q])[:, None, :]                      # (2, 1, 2) against (K, 2)
    to_them = closest_on_segments(ends, a[None], b[None])[2].min(axis=0)
    to_us = closest_on_segments(np.stack([a, b]), p, q)[2].min(axis=0)
    return np.minimum(to_them, to_us)


def _bridge_too_close(graph: StreetGraph, p: NDArray[np.float64], q: NDArray[np.float64], spacing: float) -> bool:
    if spacing <= 0:
        return False
    ids = np.flatnonzero(graph.bridge)
    if len(ids) == 0:
        return False
    a, b = graph.segment_ends(ids)
    close = _segment_distance(p, q, a, b) < spacing
    close |= _intersects(p, q, a, b)
    return bool(close.any())
