"""Give grown streets real shapes and dead ends back (what 004 §6.2 says it lost).

Dead ends: per level, the example's dead ends per junction say how many
stubs to add. A stub leaves a junction that has a free slot, across its
street, with about the example's mean dead-end length, and only where it
crosses nothing, stays in the region and stays out of the obstacles.

Shapes: each new junction-to-junction segment borrows the shape of a random
example piece of the same level, expressed in that piece's own frame (along
the chord and across it, in chord lengths) and laid onto the new chord. A
shape that would touch anything already drawn stays straight.
"""
from __future__ import annotations

import numpy as np
import shapely

from osm_expand.model.topology import junction_mask, junction_stops, spaced_points
from simplify.example import Example
from synth.segment_index import SegmentIndex

Street = tuple[int, list[int]]


def piece_profiles(example: Example) -> dict[int, list[np.ndarray]]:
    """Per level, the example's curved junction-to-junction shapes in chord coordinates (t, s)."""
    net = example.network
    junction = junction_mask(net.streets, len(net.xy))
    out: dict[int, list[np.ndarray]] = {}
    for s in net.streets:
        pos = junction_stops(s, junction)
        for a, b in zip(pos, pos[1:]):
            pts = net.xy[list(s.nodes[a:b + 1])]
            chord = pts[-1] - pts[0]
            length = float(np.hypot(*chord))
            if length < 1.0:
                continue
            u = chord / length
            rel = pts - pts[0]
            out.setdefault(s.hierarchy, []).append(np.column_stack([rel @ u, rel @ np.array([-u[1], u[0]])]) / length)
    return out


def lay(profile: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A (t, s) profile laid onto the chord a→b."""
    chord = b - a
    pts = a + profile[:, :1] * chord + profile[:, 1:] * np.array([-chord[1], chord[0]])
    pts[0], pts[-1] = a, b
    return pts


#: Shape points closer than this to their kept neighbours are dropped (m): OSM's 7 decimals are ~1 cm.
MIN_SHAPE_STEP = 1.0


def add_dead_ends(example: Example, xy: np.ndarray, streets: list[Street], region, obstacles,
                  rng: np.random.Generator, index: SegmentIndex,
                  segment: dict[tuple[int, int], int]) -> tuple[np.ndarray, list[Street]]:
    """The cloud with stub tips appended, and the stubs as two-junction streets.

    ``index`` holds every segment drawn so far (``segment`` their ids); the stubs are added to both.
    """
    chords = [(a, b) for _, path in streets for a, b in zip(path, path[1:])]
    degree = np.bincount(np.array(chords, dtype=np.int64).ravel(), minlength=len(xy)) if chords else np.zeros(len(xy))
    tips: list[np.ndarray] = []
    stubs: list[Street] = []
    for lv, path in streets:
        rate = example.dead_ends_per_level.get(lv, {}).get("per_junction", 0.0)
        length = example.dead_ends_per_level.get(lv, {}).get("mean_length_m", 0.0)
        for i in range(1, len(path) - 1):
            n = path[i]
            if degree[n] >= 4 or length <= 0 or rng.random() >= rate / 2:  # two streets share the rate
                continue
            d = xy[path[i + 1]] - xy[path[i - 1]]
            across = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
            tip = xy[n] + across * length * rng.uniform(0.6, 1.2) * (1 if rng.random() < 0.5 else -1)
            stub = shapely.LineString([xy[n], tip])
            tip_id = len(xy) + len(tips)
            if not region.covers(stub) or (obstacles is not None and obstacles.intersects(stub)) \
                    or index.crosses(xy[n], tip, n, tip_id):
                continue
            segment[(n, tip_id)] = segment[(tip_id, n)] = index.add(xy[n], tip, n, tip_id)
            degree[n] += 1
            tips.append(tip)
            stubs.append((lv, [n, tip_id]))
    return (np.vstack([xy] + [t[None] for t in tips]) if tips else xy), stubs


def shaped_streets(example: Example, xy: np.ndarray, streets: list[Street], obstacles,
                   rng: np.random.Generator, index: SegmentIndex, segment: dict[tuple[int, int], int],
                   region=None) -> list[tuple[int, np.ndarray]]:
    """Polylines for the streets, each segment shaped like an example piece of its level where it fits.

    ``index`` holds every segment drawn (``segment`` their ids); a shaped one replaces its chord there.
    """
    profiles = piece_profiles(example)
    chords = list(dict.fromkeys((a, b) for _, path in streets for a, b in zip(path, path[1:])))
    level_of = {(a, b): lv for lv, path in streets for a, b in zip(path, path[1:])}
    shapes: dict[tuple[int, int], np.ndarray] = {}
    next_id = len(xy)
    for a, b in chords:
        shapes[(a, b)] = np.array([xy[a], xy[b]])
        choices = profiles.get(level_of[(a, b)])
        if not choices:
            continue
        pts = lay(choices[int(rng.integers(len(choices)))], xy[a], xy[b])
        pts = pts[spaced_points(pts, MIN_SHAPE_STEP)]
        if len(pts) < 3 or not shapely.LineString(pts).is_simple:
            continue
        if obstacles is not None and obstacles.intersects(shapely.LineString(pts)):
            continue
        if region is not None and not region.covers(shapely.LineString(pts)):
            continue
        index.remove(segment[(a, b)])
        names = [a] + list(range(next_id, next_id + len(pts) - 2)) + [b]
        if any(index.crosses(p, q, u, v) for p, q, u, v in zip(pts, pts[1:], names, names[1:])):
            segment[(a, b)] = segment[(b, a)] = index.add(xy[a], xy[b], a, b)  # keep it straight
            continue
        next_id += len(pts) - 2
        for p, q, u, v in zip(pts, pts[1:], names, names[1:]):
            index.add(p, q, u, v)
        shapes[(a, b)] = pts
    out = []
    for lv, path in streets:
        parts = [shapes[(a, b)] for a, b in zip(path, path[1:])]
        out.append((lv, np.vstack([parts[0]] + [p[1:] for p in parts[1:]])))
    return out
