"""The input of the measures: polylines gathered once, so that many windows can be measured on them."""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

__all__ = ["LineSet"]


@dataclass(frozen=True, eq=False)
class LineSet:
    """Polylines gathered once, so that many windows can be measured on them.

    ``coords`` ``(P, 2)`` metres of every line one after the other,
    ``line_of`` ``(P,)`` the line each point belongs to, ``geoms`` the
    lines as shapely LineStrings and ``tree`` an STRtree over them.
    """

    coords: np.ndarray
    line_of: np.ndarray
    geoms: np.ndarray
    tree: shapely.STRtree

    @classmethod
    def from_lines(cls, lines: Sequence[np.ndarray] | LineSet) -> LineSet:
        """Gather ``lines`` (each ``(n_i, 2)`` metres; lines of fewer than 2 points are dropped)."""
        if isinstance(lines, LineSet):
            return lines
        arrays = [np.asarray(ln, dtype=np.float64).reshape(-1, 2) for ln in lines]
        arrays = [a for a in arrays if len(a) >= 2]
        if arrays:
            coords = np.concatenate(arrays)
            line_of = np.repeat(np.arange(len(arrays)), [len(a) for a in arrays])
            geoms = shapely.linestrings(coords, indices=line_of)
        else:
            coords, line_of, geoms = np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.empty(0, dtype=object)
        return cls(coords=coords, line_of=line_of, geoms=geoms, tree=shapely.STRtree(geoms))

    def hull(self, margin: float) -> shapely.Polygon:
        """The convex hull of all points grown by ``margin`` metres (an empty polygon when no line)."""
        if len(self.coords) == 0:
            return shapely.Polygon()
        return shapely.multipoints(self.coords).convex_hull.buffer(margin)

    def clip(self, window: shapely.Geometry) -> tuple[np.ndarray, np.ndarray]:
        """Points and line labels of the pieces of the lines inside ``window``.

        Lines wholly inside are taken as they are; only those crossing the
        boundary go through a shapely intersection.
        """
        cand = self.tree.query(window)
        if len(cand) == 0:
            return np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
        shapely.prepare(window)
        geoms = self.geoms[cand]
        inside = shapely.contains_properly(window, geoms)
        keep = np.zeros(len(self.geoms), dtype=bool)
        keep[cand[inside]] = True
        mask = keep[self.line_of]
        crossing = geoms[~inside][shapely.intersects(window, geoms[~inside])]
        pieces = shapely.get_parts(shapely.intersection(crossing, window))
        pieces = pieces[shapely.get_type_id(pieces) == 1]  # LineStrings; touching points drop out
        xy, label = shapely.get_coordinates(pieces, return_index=True)
        return (np.concatenate([self.coords[mask], xy]),
                np.concatenate([self.line_of[mask], label + len(self.geoms)]))
