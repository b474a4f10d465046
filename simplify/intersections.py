"""Pass 1 (004 §4.2.1): intersection extraction.

Junctions are the nodes shared by two or more streets, or visited twice by
one. Streets that touch themselves are cut there, so from here on "shared by
two streets" is the only junction rule. Shape points are kept as geometry.
"""
from __future__ import annotations

from osm_expand.model import StreetNetwork
from osm_expand.model.topology import split_self_touching


def extract_intersections(net: StreetNetwork) -> StreetNetwork:
    streets = tuple(p for s in net.streets for p in split_self_touching(s))
    return net.replace(streets=streets)
