"""Reproduction (004 §5.3): re-walk a town's own junctions in place and score the result.

Recall is the share of the example's junction-to-junction segments that the
walk re-creates; precision the share of the walk's segments that exist in
the example. 004 reports about 70 ± 5 %.
"""
from __future__ import annotations

from collections import defaultdict

import numpy as np

from osm_expand.model.topology import junction_mask, junction_stops
from simplify.example import Example
from synth.walk import NodeCloud, WalkOptions, WalkResult, random_walk


def cloud_from_example(ex: Example) -> NodeCloud:
    return NodeCloud.from_example(ex)


def example_segments(ex: Example) -> dict[tuple[int, int], int]:
    """The example's junction-to-junction segments (junction ids) and their street's level."""
    net = ex.network
    junction = junction_mask(net.streets, len(net.xy))
    jid = np.full(len(net.xy), -1)
    jid[ex.junctions] = np.arange(len(ex.junctions))
    out: dict[tuple[int, int], int] = {}
    for s in net.streets:
        ids = [int(jid[s.nodes[p]]) for p in junction_stops(s, junction)]
        for a, b in zip(ids, ids[1:]):
            if a != b:
                out[(min(a, b), max(a, b))] = s.hierarchy
    return out


def score(truth: dict[tuple[int, int], int], walk: WalkResult) -> dict:
    made = {(min(a, b), max(a, b)): lv for lv, p in walk.streets for a, b in zip(p, p[1:])}
    hits = made.keys() & truth.keys()
    tally: defaultdict[int, list[int]] = defaultdict(lambda: [0, 0, 0, 0])  # true, found, made, right
    for seg, lv in truth.items():
        tally[lv][0] += 1
        tally[lv][1] += seg in made
    for seg, lv in made.items():
        tally[lv][2] += 1
        tally[lv][3] += seg in truth
    per_level = {lv: {"recall": found / n_true if n_true else 1.0, "precision": right / n_made if n_made else 1.0}
                 for lv, (n_true, found, n_made, right) in sorted(tally.items())}
    return {
        "recall": len(hits) / len(truth) if truth else 1.0,
        "precision": len(hits) / len(made) if made else 1.0,
        "segments_original": len(truth),
        "segments_made": len(made),
        "per_level": per_level,
    }


def reproduce(ex: Example, seed: int = 0, options: WalkOptions | None = None) -> dict:
    """Walk the example's junctions in place; recall and precision, overall and per level."""
    walk = random_walk(cloud_from_example(ex), seed=seed, options=options)
    return {"seed": seed, **score(example_segments(ex), walk)}
