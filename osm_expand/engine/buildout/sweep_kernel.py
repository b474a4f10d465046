"""The pair sweep's search over spans, compiled (:func:`best_span`), for
:func:`osm_expand.engine.buildout.footprints._sweep` without a size target.

The numpy sweep builds a dozen (S, S) arrays for each street edge tried, S
about 55 samples: a few thousand values each, so its time was numpy's call
overhead, not arithmetic (Krems' 150 north-american years: 20,835 sweeps,
about 260 µs each). The loop here visits the same spans in the same order
(row-major, i < j) and computes each with the same operations in the same
order (additions, products and minima of float64, no fused or reordered
arithmetic), so the best span and its sides are the same numbers
(``tests/test_footprints.py`` compares the two on random lots).

The kernel is compiled by numba on first use and cached (``_compiled``,
:mod:`osm_expand.engine.roads.expanded_search`); this module, and with it
numba, is imported only when a building is placed.
"""
from __future__ import annotations

import math

import numpy as np

from osm_expand.engine.roads.expanded_search import _compiled

__all__ = ["best_span"]


@_compiled()
def best_span(u: np.ndarray, right_of: np.ndarray, left_of: np.ndarray, side: float, back: float,
              max_ratio: float, min_side: float, length: float) -> tuple[int, int, float, float]:
    """The span (i, j) of samples ``u`` with the largest building and its frontage and depth; i = -1: none.

    For each pair i < j: the free depth over (u_i, u_j) is the least of h(u_i+), h(u_j-) and the
    samples strictly between (``both``); the room is that span less the side setbacks by that depth
    less the back setback; the building is the room cut to ``max_ratio``; it counts when both are
    positive and its shorter side is at least ``min_side``. Score: its area, less 1e-6 per metre of
    its centre from the edge's middle; the first best in row-major order wins (numpy's argmax).
    """
    s = len(u)
    least = max(min_side, 1e-9)
    best_i, best_j, best_w, best_d = -1, -1, 0.0, 0.0
    best = -np.inf
    for i in range(s):
        gap = np.inf  # least of min(right_of, left_of) over samples i+1 .. j-1
        for j in range(i + 1, s):
            low = min(min(right_of[i], left_of[j]), gap)
            width = u[j] - u[i] - 2.0 * side
            depth = low - back
            w = max(width, 0.0)
            d = max(depth, 0.0)
            w = min(w, max_ratio * d)
            d = min(d, max_ratio * w)
            if width > 0 and depth > 0 and math.isfinite(low) and min(w, d) >= least:
                centre = 0.5 * (u[j] + u[i])
                score = w * d - 0.0 - 1e-6 * abs(centre - 0.5 * length)
                if score > best:
                    best, best_i, best_j, best_w, best_d = score, i, j, w, d
            gap = min(gap, min(right_of[j], left_of[j]))
    return best_i, best_j, best_w, best_d
