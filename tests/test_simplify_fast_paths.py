"""The fast paths of simplification equal the plain algorithms they replaced, result for result.

Each plain version below is the earlier code, kept here as the definition:
dead ends pruned by a queue over every street with a full node index; the
clean-up repeating whole rounds; headings walked street by street; street
counts from ``np.unique``; the overlap check asking GEOS about every pair.
"""
from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest
import shapely
from conftest import FIXTURES
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import simplify.pipeline as pipeline
from osm_expand.gcpause import cyclic_gc_paused
from osm_expand.ingest import load
from osm_expand.model import network_from_lines
from osm_expand.model.topology import end_angles, heading, headings, lengths, street_counts
from simplify import SimplifyOptions, simplify
from simplify.cleanup import MAX_ROUNDS, cleanup
from simplify.crossings import candidate_pairs, segment_table
from simplify.dead_ends import DeadEnd, prune, prune_dead_ends
from simplify.intersections import extract_intersections
from simplify.invariants import _unshared_crossings
from simplify.merging import end_angle
from simplify.overlaps import OverlapPlan, remove_overlaps
from simplify.streetset import StreetSet

OPTS = SimplifyOptions()
TOWNS = ["krems.osm.gz", "monaco.osm.gz", "andorra.osm.pbf", "north-bayreuth.osm.gz", "campo-grande.osm.gz"]


# -- the plain versions ---------------------------------------------------------------

def plain_prune(net):
    """Every street queued, highest index first; a node → streets index of the whole network."""
    work = StreetSet(net.streets)
    removed = []
    queue = sorted(work.streets)
    while queue:
        k = queue.pop()
        if k not in work.streets or work.streets[k].is_closed:
            continue
        street = work.streets[k]
        nodes = list(street.nodes)
        start = next((i for i, n in enumerate(nodes) if work.count(n) >= 2), None)
        if start is None:
            removed.append(DeadEnd(-1, lengths(net.xy, nodes), street.highway))
            work.remove(k)
            continue
        end = len(nodes) - 1 - next(i for i, n in enumerate(nodes[::-1]) if work.count(n) >= 2)
        if start > 0:
            removed.append(DeadEnd(nodes[start], lengths(net.xy, nodes[:start + 1]), street.highway))
        if end < len(nodes) - 1:
            removed.append(DeadEnd(nodes[end], lengths(net.xy, nodes[end:]), street.highway))
        if start == 0 and end == len(nodes) - 1:
            continue
        if end - start < 1:
            work.remove(k)
            node = nodes[start]
            if work.count(node) == 1:
                (j,) = work.at[node]
                s = work.streets[j]
                if node in (s.nodes[0], s.nodes[-1]) and not s.is_closed:
                    queue.append(j)
        else:
            work.replace(k, street.with_nodes(nodes[start:end + 1]))
    return net.replace(streets=work.ordered()), removed


def plain_keeping_cycles(net, opts):
    exempt = frozenset()
    for _ in range(MAX_ROUNDS):
        trial, removed = remove_overlaps(net, opts, exempt)
        if not removed:
            return trial, removed
        pruned, dead = plain_prune(trial)
        if not dead:
            return trial, removed
        lost = set(trial.used_nodes().tolist()) - set(pruned.used_nodes().tolist())
        lost |= {d.attach for d in dead}
        holding = {key for key in removed if key[0] in lost or key[1] in lost}
        if not holding:
            return trial, removed
        exempt = exempt | holding
    return remove_overlaps(net, opts, exempt)


def plain_cleanup(net, opts):
    pieces, dead_ends = 0, []
    for _ in range(MAX_ROUNDS):
        net, removed = plain_keeping_cycles(net, opts)
        net, dead = plain_prune(net)
        dead_ends += dead
        pieces += len(removed)
        if not removed and not dead:
            break
    return net, pieces, dead_ends


def plain_street_counts(streets, n):
    nodes = np.fromiter((v for s in streets for v in s.nodes), dtype=np.int64)
    owner = np.repeat(np.arange(len(streets), dtype=np.int64), [len(s.nodes) for s in streets])
    return np.bincount(np.unique(owner * n + nodes) % n, minlength=n).astype(np.int32)


def plain_segment_table(net):
    keys, cols = {}, {c: [] for c in ("u", "v", "street", "pos", "layer")}
    for k, s in enumerate(net.streets):
        n = len(s.nodes) - 1
        cols["u"].append(s.nodes[:-1])
        cols["v"].append(s.nodes[1:])
        cols["street"].append(np.full(n, k))
        cols["pos"].append(np.arange(n))
        cols["layer"].append(np.full(n, keys.setdefault(s.layer_key, len(keys))))
    return {c: np.concatenate(parts).astype(np.intp) for c, parts in cols.items()}


def plain_unshared(net, seg):
    p, q, shares = candidate_pairs(net, seg, 0.0)
    bad = int((~shares).sum())
    both = np.flatnonzero(shares)
    lines = shapely.linestrings(np.stack([net.xy[seg["u"]], net.xy[seg["v"]]], axis=1))
    inter = shapely.intersection(lines[p[both]], lines[q[both]])
    return bad + int(np.isin(shapely.get_type_id(inter), (1, 5)).sum())


# -- networks to compare on -------------------------------------------------------------

@pytest.fixture(scope="module", params=TOWNS)
def town(request):
    return extract_intersections(load(FIXTURES / request.param, context=False).network)


coord = st.integers(min_value=0, max_value=30).map(lambda v: v * 10.0)
polyline = st.lists(st.tuples(coord, coord), min_size=2, max_size=6)
attrs = st.fixed_dictionaries({"highway": st.sampled_from(["primary", "residential"]),
                               "layer": st.sampled_from([0, 0, 1]), "name": st.sampled_from([None, "A"])})
line_sets = st.lists(st.tuples(polyline, attrs), min_size=1, max_size=25)


def random_network(lines):
    return extract_intersections(network_from_lines([p for p, _ in lines], [a for _, a in lines]))


def same_network(a, b):
    return a.streets == b.streets and np.array_equal(a.xy, b.xy)


# -- dead ends ----------------------------------------------------------------------

def test_worklist_pruning_equals_the_queue_over_every_street_on_towns(town):
    fast, dead = prune_dead_ends(town)
    slow, slow_dead = plain_prune(town)
    assert same_network(fast, slow) and dead == slow_dead and dead


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(line_sets)
def test_worklist_pruning_equals_the_queue_over_every_street(lines):
    net = random_network(lines)
    pruned = prune(net)
    slow, slow_dead = plain_prune(net)
    assert same_network(pruned.network, slow) and pruned.dead == slow_dead
    lost = set(net.used_nodes().tolist()) - set(slow.used_nodes().tolist())
    assert pruned.lost == lost


# -- the clean-up -------------------------------------------------------------------

def test_cleanup_equals_whole_rounds_through_every_pass(town, monkeypatch):
    """Every clean-up the pipeline runs on a real town, against the plain rounds on the same input."""
    calls = []

    def checked(net, opts):
        fast = cleanup(net, opts)
        slow = plain_cleanup(net, opts)
        assert same_network(fast[0], slow[0]) and fast[1:] == slow[1:]
        calls.append(fast[1] + len(fast[2]))
        return fast

    monkeypatch.setattr(pipeline, "cleanup", checked)
    simplify(town)
    assert len(calls) >= 6 and sum(calls) > 0


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(line_sets)
def test_cleanup_equals_whole_rounds(lines):
    net = random_network(lines)
    fast, slow = cleanup(net, OPTS), plain_cleanup(net, OPTS)
    assert same_network(fast[0], slow[0]) and fast[1:] == slow[1:]


def test_an_overlap_plan_gives_what_remove_overlaps_gives_for_any_exemption(town):
    plan = OverlapPlan(town, OPTS)
    trial, removed = plan.remove()
    for exempt in (frozenset(), frozenset(removed[: len(removed) // 2]), frozenset(removed)):
        a, b = plan.remove(exempt), remove_overlaps(town, OPTS, exempt)
        assert same_network(a[0], b[0]) and a[1] == b[1]


# -- headings, counts, segments, the invariant check ---------------------------------

@pytest.mark.parametrize("reach", [0.0, 5.0, 20.0, 1e6])
def test_headings_are_bit_for_bit_those_of_heading(town, reach):
    k = np.repeat(np.arange(len(town.streets)), 2)
    first = np.tile([True, False], len(town.streets))
    fast = headings(town.xy, town.streets, k, first, reach, width=4)  # a narrow walk: the fallback is used too
    slow = np.array([heading(town.xy, town.streets[i].nodes, f, reach) for i, f in zip(k.tolist(), first.tolist())])
    assert np.array_equal(fast, slow, equal_nan=True)


def test_end_angles_are_bit_for_bit_those_of_end_angle(town):
    streets = town.streets[:400]
    pairs = list(combinations(range(len(streets)), 2))[:20000]
    a = np.array([i for i, _ in pairs])
    b = np.array([j for _, j in pairs])
    h = headings(town.xy, streets, np.concatenate([a, b]), np.ones(2 * len(pairs), dtype=bool), OPTS.heading_reach)
    fast = end_angles(h[: len(pairs)], h[len(pairs):])
    slow = [end_angle(town.xy, streets[i], True, streets[j], True, OPTS.heading_reach) for i, j in pairs]
    assert np.array_equal(fast, np.array(slow), equal_nan=True)


def test_street_counts_and_segment_table_equal_the_plain_ones(town):
    assert np.array_equal(street_counts(town.streets, len(town.xy)), plain_street_counts(town.streets, len(town.xy)))
    fast, slow = segment_table(town), plain_segment_table(town)
    assert all(np.array_equal(fast[c], slow[c]) for c in slow)


def test_the_overlap_check_counts_what_geos_counts_on_every_pair(town):
    raw = load(FIXTURES / "andorra.osm.pbf", context=False).network  # raw Andorra has overlapping segments
    for net in (town, raw, simplify(town).network):
        seg = segment_table(net)
        assert _unshared_crossings(net, seg) == plain_unshared(net, seg)


@pytest.mark.parametrize("second, overlaps", [([(0, 0), (60, 0)], 1), ([(100, 0), (0, 0)], 1),
                                              ([(0, 0), (-50, 0)], 0), ([(0, 0), (100, 1e-9)], None)])
def test_collinear_overlap_from_a_shared_node_is_still_found(second, overlaps):
    """Along the first segment, reversed on it, straight away from it, and a hair off it (GEOS decides)."""
    net = network_from_lines([[(0, 0), (100, 0)], second])
    seg = segment_table(net)
    assert _unshared_crossings(net, seg) == plain_unshared(net, seg)
    assert overlaps is None or _unshared_crossings(net, seg) == overlaps


# -- the garbage-collector pause -------------------------------------------------------

def test_the_collector_pause_restores_the_state_it_found():
    import gc

    assert gc.isenabled()
    with cyclic_gc_paused():
        assert not gc.isenabled()
        with cyclic_gc_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()
    assert gc.isenabled()
    gc.disable()
    try:
        with cyclic_gc_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()
