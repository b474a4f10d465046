"""Numbers that describe a town's streets, for ``osm-expand stats`` and for tests.

Junction spacing and turning angle per Gravelius level (what the random walk
reproduces), the shares of 3- and 4-way junctions, the dead-end share, total
length, and Boeing's street-orientation entropy (36 bins of 10°, segments
weighted by length and counted in both directions).
"""
from __future__ import annotations

import math

import numpy as np

from simplify.example import Example

GRID_ENTROPY = math.log(4)  # a perfect four-way grid
MAX_ENTROPY = math.log(36)


def orientation_entropy(segments: np.ndarray, weights: np.ndarray | None = None) -> float:
    """Entropy (nats) of segment bearings in 36 bins centred on 0°, 10°, ... (Boeing 2019)."""
    if len(segments) == 0:
        return 0.0
    d = segments[:, 1] - segments[:, 0]
    bearing = np.degrees(np.arctan2(d[:, 0], d[:, 1])) % 360.0
    w = np.hypot(*d.T) if weights is None else weights
    both = np.concatenate([bearing, (bearing + 180.0) % 360.0])
    counts = np.bincount(((both + 5.0) // 10.0).astype(int) % 36, weights=np.concatenate([w, w]), minlength=36)
    p = counts[counts > 0] / counts.sum()
    return float(-(p * np.log(p)).sum())


def orientation_order(entropy: float) -> float:
    """Boeing's φ: 1 for a perfect grid, 0 for uniformly spread bearings."""
    return 1.0 - ((entropy - GRID_ENTROPY) / (MAX_ENTROPY - GRID_ENTROPY)) ** 2


def _describe(values: np.ndarray) -> dict[str, float]:
    if len(values) == 0:
        return {"n": 0}
    return {"n": int(len(values)), "mean": round(float(values.mean()), 3), "std": round(float(values.std()), 3),
            "median": round(float(np.median(values)), 3)}


def example_statistics(example: Example, dead_ends_removed: int | None = None) -> dict:
    net = example.network
    segments = np.concatenate([np.stack([net.street_xy(s)[:-1], net.street_xy(s)[1:]], axis=1)
                               for s in net.streets]) if net.streets else np.zeros((0, 2, 2))
    entropy = orientation_entropy(segments)
    n_junctions = len(example.junctions)
    degree = example.degree
    levels = {}
    for lv in sorted({s.level for s in example.streets}):
        ss = [s for s in example.streets if s.level == lv]
        levels[str(lv)] = {
            "streets": len(ss),
            "junction_spacing_m": _describe(np.concatenate([s.spacing for s in ss])),
            "turning_angle_deg": _describe(np.concatenate([s.turning for s in ss])),
            "tortuosity": _describe(np.concatenate([s.tortuosity for s in ss])),
        }
    out = {
        "junctions": n_junctions,
        "streets": len(net.streets),
        "levels": len(levels),
        "total_length_km": round(float(np.hypot(*(segments[:, 1] - segments[:, 0]).T).sum()) / 1000, 3),
        "three_way_share": round(float((degree == 3).mean()), 4) if n_junctions else 0.0,
        "four_way_share": round(float((degree == 4).mean()), 4) if n_junctions else 0.0,
        "junction_spacing_m": _describe(np.concatenate([s.spacing for s in example.streets] or [np.zeros(0)])),
        "turning_angle_deg": _describe(np.concatenate([s.turning for s in example.streets] or [np.zeros(0)])),
        "orientation_entropy": round(entropy, 4),
        "orientation_order": round(orientation_order(entropy), 4),
        "per_level": levels,
        "dead_ends_per_level": {str(k): v for k, v in example.dead_ends_per_level.items()},
    }
    if dead_ends_removed is not None:
        out["dead_end_share"] = round(dead_ends_removed / max(dead_ends_removed + n_junctions, 1), 4)
    return out
