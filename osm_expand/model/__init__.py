"""The model every stage shares: the city, its streets, and the helpers all packages need.

``simplify`` and ``synth`` import only from here (and :mod:`osm_expand.errors`):

- :mod:`~osm_expand.model.city` — :class:`City`, :class:`Building`, :class:`Block`, :class:`MappedArea`
- :mod:`~osm_expand.model.land` — :class:`Land`: frontage, settlement and land cover, the blocks that are town
- :mod:`~osm_expand.model.network` — :class:`Street`, :class:`StreetNetwork`, :class:`Origin`, :class:`Status`
- :mod:`~osm_expand.model.topology` — junctions, pieces and degrees of a network
- :mod:`~osm_expand.model.geometry` — lengths, closest points, node matching, rectangles
- :mod:`~osm_expand.model.highways` — which ``highway=*`` values are streets, and their rank
- :mod:`~osm_expand.model.projection` — the local metric projection
- :mod:`~osm_expand.model.segments` — :class:`~osm_expand.model.segments.SegmentTable`: the streets as straight
  segments with per-segment columns (what the engine computes on); :mod:`~osm_expand.model.pieces` — where
  each segment of an older table went (imported from their modules: the command line's start-up stays light)
"""
from osm_expand.model.city import (
                                   Block,
                                   Building,
                                   City,
                                   Lot,
                                   MappedArea,
                                   SourceFile,
                                   UnplacedWay,
                                   demolished_ways,
                                   held_ways,
)
from osm_expand.model.geometry import chord_bends, closest_on_segments, match_points, polyline_length, turn_angles
from osm_expand.model.land import Land
from osm_expand.model.network import (
                                   Context,
                                   Origin,
                                   Status,
                                   Street,
                                   StreetNetwork,
                                   network_from_lines,
)
from osm_expand.model.projection import LocalProjection

__all__ = ["Block", "Building", "City", "Context", "Land", "LocalProjection", "Lot", "MappedArea", "Origin",
           "SourceFile", "Status", "Street", "StreetNetwork", "UnplacedWay", "chord_bends", "closest_on_segments",
           "demolished_ways", "held_ways", "match_points", "network_from_lines", "polyline_length",
           "turn_angles"]
