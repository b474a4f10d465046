"""Tunable thresholds of the simplifier, with the reasons for their defaults."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SimplifyOptions:
    #: Disc radius (m) for node-cluster fusing (004 §4.2.4): junctions whose
    #: discs overlap (closer than twice this) fuse. 10 m joins the two
    #: carriageways of a dual road and the nodes of a complex junction, like
    #: osmnx's ``consolidate_intersections(tolerance=10)``.
    cluster_radius: float = 10.0
    #: Tagged roundabouts (``junction=roundabout|circular``) up to this
    #: diameter (m) collapse to their centroid; larger ones (Berlin's Großer
    #: Stern) are real streets with their own junctions and stay.
    roundabout_max_diameter: float = 80.0
    #: Untagged closed street loops up to this diameter (m) are treated as
    #: roundabouts (004 §4.2.3: loops are more reliable than the tag).
    loop_max_diameter: float = 40.0
    #: Street pieces that leave a junction and return to it, shorter than
    #: this (m), are clutter (turning loops, slip lanes after a collapse).
    small_loop_length: float = 150.0
    #: Two pieces between the same two junctions are one street drawn twice
    #: when their Hausdorff distance is at most this (m) (004 §4.2.1).
    overlap_tolerance: float = 25.0
    #: Streets continue through a junction when they meet at more than this
    #: angle (degrees) (004 §4.2.5).
    merge_angle: float = 160.0
    #: Directions at a street end are measured towards the point this far
    #: (m) along the street, not along the first shape segment.
    heading_reach: float = 20.0
    #: How far (m) along the Passing street a separated street's end moves
    #: when cutting it back would delete it whole (004 §3.1, §4.2.6).
    separation: float = 8.0
    #: A vertex this close (m) to another street's segment on the same layer
    #: touches it and becomes a junction; survives rounding to 1e-7 degrees.
    touch_tolerance: float = 0.05
    #: Consecutive shape points closer than this (m) are dropped at the end,
    #: so exported coordinates never collapse into one another.
    min_vertex_spacing: float = 0.5
