"""Overlaps and dead ends, removed in turn until neither changes anything.

Passes that move nodes (roundabouts, clusters, merging, the two-street rule)
leave duplicates, small loops and dead ends behind; every one of them is
followed by this clean-up. Removing a duplicate can expose a dead end (the
duplicate was the only cycle holding a stretch of road), so such pieces are
exempted and kept.

Each step here is a pure function of the network, so a round whose inputs
equal the last round's would repeat it exactly: it is skipped, and the
pruning done while choosing the exemptions is handed on, not done again.
"""
from __future__ import annotations

from osm_expand.model import StreetNetwork
from simplify.dead_ends import DeadEnd, Pruned, prune
from simplify.options import SimplifyOptions
from simplify.overlaps import OverlapPlan, PieceKey

MAX_ROUNDS = 8


def cleanup(net: StreetNetwork, opts: SimplifyOptions) -> tuple[StreetNetwork, int, list[DeadEnd]]:
    """Overlaps and dead ends until neither changes: the network, pieces removed, dead ends removed."""
    pieces_removed, dead_ends = 0, []
    for _ in range(MAX_ROUNDS):
        net, pieces, pruned = remove_overlaps_keeping_cycles(net, opts)
        pruned = pruned or prune(net)
        net = pruned.network
        dead_ends += pruned.dead
        pieces_removed += len(pieces)
        if not pieces and not pruned.dead:
            break
    return net, pieces_removed, dead_ends


def remove_overlaps_keeping_cycles(net: StreetNetwork, opts: SimplifyOptions
                                   ) -> tuple[StreetNetwork, list[PieceKey], Pruned | None]:
    """Remove duplicates and small loops, except those whose removal would expose dead ends.

    Dead-end pruning keeps exactly the streets on or between cycles. When a
    removed piece was the only cycle holding a stretch of road, pruning
    would now delete that road; such pieces are kept and the rest removed.
    Returns the network, the removed pieces' junction pairs and, when it was
    computed on the way, the pruning of the returned network.
    """
    plan = OverlapPlan(net, opts)
    exempt: frozenset[PieceKey] = frozenset()
    for _ in range(MAX_ROUNDS):
        trial, removed = plan.remove(exempt)
        if not removed:
            return trial, removed, None
        pruned = prune(trial)
        lost = pruned.lost | {d.attach for d in pruned.dead}
        holding = {key for key in removed if key[0] in lost or key[1] in lost}
        if holding <= exempt:  # nothing held, or the same exemptions again: every later round is this one
            return trial, removed, pruned
        exempt = exempt | holding
    trial, removed = plan.remove(exempt)
    return trial, removed, None
