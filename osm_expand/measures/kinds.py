"""Which measures there are, their options, and what measuring a network returns (:mod:`osm_expand.measures`)."""
from __future__ import annotations

from dataclasses import dataclass, fields
from enum import StrEnum

import numpy as np

from osm_expand.errors import InputError
from osm_expand.model.options import require_positive

__all__ = ["DISTRIBUTIONS", "SCALARS", "Measure", "MeasureOptions", "NetworkMeasures", "measure_named"]


class Measure(StrEnum):
    """The fourteen measures, in report order: eight distributions, then six scalars."""

    EDGE_LENGTH = "edge_length"
    CIRCUITY = "circuity"
    STROKE_LENGTH = "stroke_length"
    JUNCTION_ANGLE = "junction_angle"
    BLOCK_AREA = "block_area"
    BLOCK_COMPACTNESS = "block_compactness"
    ALIGNMENT = "alignment"
    CURVATURE = "curvature"
    DENSITY = "density"
    ORIENTATION_ENTROPY = "orientation_entropy"
    THREE_WAY_SHARE = "three_way_share"
    FOUR_WAY_SHARE = "four_way_share"
    DEAD_END_SHARE = "dead_end_share"
    TWO_CORE_SHARE = "two_core_share"


DISTRIBUTIONS: tuple[Measure, ...] = tuple(Measure)[:8]
SCALARS: tuple[Measure, ...] = tuple(Measure)[8:]


def measure_named(name: Measure | str) -> Measure:
    """The :class:`Measure` called ``name``; :class:`InputError` listing the valid names otherwise."""
    try:
        return Measure(name)
    except ValueError:
        raise InputError(f"unknown measure {name!r} (valid: {', '.join(m.value for m in Measure)})") from None


@dataclass(frozen=True)
class MeasureOptions:
    #: m: coordinates equal after rounding to this are one node. 1 cm keeps
    #: OSM's 1e-7° (≈ 1 cm) apart and joins what a writer rounded.
    node_precision: float = 0.01
    #: m: a line end this close to the window's boundary was made by the
    #: clip (or an open point this close to a node marks it open). 1 m covers
    #: a disc drawn as a 64-gon (its sagitta is < 0.1 % of the radius).
    open_tolerance: float = 1.0
    #: m: the default window (no ``window`` given) is the convex hull grown
    #: by this, so ends on the hull are not taken for clip ends.
    hull_margin: float = 5.0
    #: m: an edge end's direction points this far along the edge; the same
    #: reach as ``SimplifyOptions.heading_reach`` (a jittery first shape
    #: segment must not decide an angle).
    heading_reach: float = 20.0
    #: degrees: edge ends continue as one stroke below this deflection (issue).
    stroke_deflection: float = 30.0
    #: m²: smaller faces are slivers between dual carriageways and in
    #: junction shapes, not blocks (a 7 m × 7 m face).
    min_block_area: float = 50.0
    #: edges each edge's chord is compared with (issue).
    alignment_neighbours: int = 6
    #: m: neighbours farther than this (by arc midpoint) are not compared (issue).
    alignment_radius: float = 150.0
    #: m: curvature samples each edge this often (issue).
    curvature_step: float = 20.0
    #: m: edges with a shorter chord have no direction for circuity and
    #: alignment (loops and tiny links).
    min_chord: float = 1.0
    #: bins of the orientation histogram (Boeing 2019: 36 of 10°).
    orientation_bins: int = 36
    #: degrees: angles (junction angles, alignment, curvature) are rounded to this. OSM's 7 decimals
    #: (about 1 cm) give a 20 m step a direction good to 0.03°; below that a KS distance only compares
    #: rounding noise (a straight grid's 3e-13° against another's 8e-13°).
    angle_resolution: float = 0.1
    #: m each side: streets buffered this much and merged make a network's pieces (issue 20: 30 m,
    #: about a building lot's depth, so a street and the houses along it are one strip of town).
    piece_buffer: float = 30.0

    def __post_init__(self) -> None:
        require_positive(self, [f.name for f in fields(self)])


@dataclass(frozen=True, eq=False)
class NetworkMeasures:
    """The measures of one network in one window (see :mod:`osm_expand.measures`).

    Distributions are 1-D float64 arrays in the order the network gives
    them; scalars are floats, NaN when undefined (shares with no junction
    or dead end, entropy with no street).
    """

    edge_length: np.ndarray
    circuity: np.ndarray
    stroke_length: np.ndarray
    junction_angle: np.ndarray
    block_area: np.ndarray
    block_compactness: np.ndarray
    alignment: np.ndarray
    curvature: np.ndarray
    density: float
    orientation_entropy: float
    three_way_share: float
    four_way_share: float
    dead_end_share: float
    two_core_share: float
    #: m of street inside the window, and the window's area (m²).
    length: float
    area: float
    junctions: int
    dead_ends: int
    open_ends: int
    edges: int
    cut_edges: int
    blocks: int
    #: pieces on the map (:mod:`osm_expand.measures`); -1 when not counted (``pieces=False``).
    pieces: int = -1
    #: measures not computed (``measure_network(wanted=...)``): empty here, and :meth:`value` refuses them.
    left_out: frozenset[Measure] = frozenset()

    def value(self, measure: Measure | str) -> np.ndarray | float:
        """One measure by name: an array for a distribution, a float for a scalar."""
        m = measure_named(measure)
        if m in self.left_out:
            raise ValueError(f"measure {m.value!r} was not computed (left out by measure_network's wanted)")
        return getattr(self, m.value)

    def counts(self) -> dict[str, float]:
        """The plain counts, JSON-ready."""
        return {"length_km": round(self.length / 1000, 3), "area_km2": round(self.area / 1e6, 4),
                "junctions": self.junctions, "dead_ends": self.dead_ends, "open_ends": self.open_ends,
                "edges": self.edges, "cut_edges": self.cut_edges, "blocks": self.blocks,
                **({"pieces": self.pieces} if self.pieces >= 0 else {})}
