"""Simplification on every real extract: invariants, reduction, fidelity, layers."""
from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
import shapely

from osm_expand.export import write_geojson, write_osm
from osm_expand.ingest import load
from osm_expand.model import City, network_from_lines
from osm_expand.model.topology import junction_mask
from simplify import SimplifyOptions, simplify
from simplify.crossings import add_missing_intersections
from simplify.intersections import extract_intersections
from simplify.invariants import violations
from simplify.quality import length_within, pruned_reference
from tests.conftest import FIXTURES, TOWNS, loaded, simplified


@pytest.mark.parametrize("name", TOWNS)
def test_simplified_network_has_no_violations(name):
    result = simplified(name)
    assert result.network.streets
    assert violations(result.network) == dict.fromkeys(violations(result.network), 0)


@pytest.mark.parametrize("name", TOWNS)
def test_osm_and_geojson_outputs_keep_the_invariants(name, tmp_path):
    """Read our own files back (lon/lat, rounded to 1e-7) and check them again."""
    net = simplified(name).network
    write_osm(City(network=net), tmp_path / "out.osm")
    back = load(tmp_path / "out.osm", context=False).network
    assert len(back.streets) == len(net.streets)
    assert not any(violations(back).values())
    assert junction_mask(back.streets, len(back.xy)).sum() == junction_mask(net.streets, len(net.xy)).sum()
    write_geojson(City(network=net), tmp_path / "out.geojson")
    doc = json.loads((tmp_path / "out.geojson").read_text())
    lines = [f["geometry"]["coordinates"] for f in doc["features"]]
    attrs = [{"layer": int(f["properties"].get("layer", 0)), "bridge": "bridge" in f["properties"],
              "tunnel": "tunnel" in f["properties"]} for f in doc["features"]]
    assert not any(violations(network_from_lines(lines, attrs)).values())


@pytest.mark.parametrize("name", ["krems.osm.gz", "north-bayreuth.osm.gz"])
def test_junctions_are_at_most_15_percent_of_input_street_nodes(name):
    report = simplified(name).report
    assert 1 - report["junctions"] / report["input_nodes"] >= 0.85


def test_campo_grande_grid_keeps_its_real_junctions():
    """Campo Grande is a dense grid: 57 % of its street nodes are real junctions already.

    Simplification removes every shape node and fuses what it should, but it
    must not delete the grid, so the reduction stays near 50 %.
    """
    report = simplified("campo-grande.osm.gz").report
    input_junctions = report["passes"][0]["junctions"]
    assert report["junctions"] < input_junctions
    assert 1 - report["junctions"] / report["input_nodes"] >= 0.45


def _two_core_reference(net):
    """The streets as read, minus cul-de-sac trees, found by networkx (not by the product's pruning):
    the 2-core of the graph of the ways' shared nodes."""
    import networkx as nx

    graph = nx.Graph()
    for s in net.streets:
        graph.add_edges_from(zip(s.nodes[:-1], s.nodes[1:]))
    graph.remove_edges_from(nx.selfloop_edges(graph))
    core = nx.k_core(graph, 2)
    lines = [[tuple(net.xy[u]), tuple(net.xy[v])] for u, v in core.edges()]
    return network_from_lines(lines)


@pytest.mark.parametrize("name", TOWNS)
def test_the_town_stays_recognisable(name):
    """At least 95 % of the length of the town's non-dead-end streets lies within 25 m of a simplified street."""
    reference = _two_core_reference(loaded(name))
    assert length_within(reference, simplified(name).network, radius=25.0) >= 0.95


@pytest.mark.parametrize("name", ["krems.osm.gz", "monaco.osm.gz"])
def test_the_independent_reference_agrees_with_the_products_pruning(name):
    ours = pruned_reference(loaded(name)).total_length()
    assert _two_core_reference(loaded(name)).total_length() == pytest.approx(ours, rel=0.10)


# Real bridges and tunnels crossing streets without a shared node: (bridge/tunnel way, crossed way).
LAYERED_CROSSINGS = {
    "monaco.osm.gz": [(92627442, 155085108),   # Tunnel vers Nationale 7 under Boulevard de Belgique
                      (80377817, 4229220),     # Avenue de Fontvieille tunnel under Boulevard Charles III
                      (92627405, 161734079)],  # primary bridge over a secondary road
    "andorra.osm.pbf": [(24364447, 6185726),   # Tunèl del Pont Pla under Carrer Sant Andreu
                        (24405095, 175417668),  # bridge over Avinguda del Pessebre
                        (6197727, 24493526)],  # Travessia d'Ordino bridge over Camí de Santa Bàrbara
    "bautzen.osm": [(4774439, 709229756),      # A4 bridge over Hoyerswerdaer Straße
                    (4774440, 318290582)],
}


def _crossing_point(net, a_id, b_id):
    line = lambda way: shapely.MultiLineString(  # noqa: E731
        [net.street_xy(s) for s in net.streets if way in s.osm_ids])
    return line(a_id).intersection(line(b_id))


def _joined_near(net, where, upper, lower) -> bool:
    """Is there a junction near ``where`` shared by streets from both ways?"""
    at = np.flatnonzero(junction_mask(net.streets, len(net.xy)))
    near = at[shapely.dwithin(shapely.points(net.xy[at]), where, 15.0)]
    for node in near.tolist():
        ids = [set(s.osm_ids) for s in net.streets if node in s.nodes]
        if any(upper in i for i in ids) and any(lower in i for i in ids):
            return True
    return False


@pytest.mark.parametrize("name", sorted(LAYERED_CROSSINGS))
def test_missing_intersection_pass_leaves_bridges_and_tunnels_alone(name):
    source = loaded(name)
    noded, _ = add_missing_intersections(extract_intersections(source), SimplifyOptions())
    for upper, lower in LAYERED_CROSSINGS[name]:
        where = _crossing_point(source, upper, lower)
        assert not where.is_empty, "the named ways cross in the input"
        assert not _joined_near(noded, where, upper, lower), (upper, lower)


@pytest.mark.parametrize("name", ["monaco.osm.gz", "andorra.osm.pbf"])
def test_simplified_bridges_and_tunnels_still_cross_without_a_junction(name):
    """In Bautzen the bridges lead off the map and go with the dead ends; here they stay."""
    source, result = loaded(name), simplified(name).network
    surviving = 0
    for upper, lower in LAYERED_CROSSINGS[name]:
        where = _crossing_point(result, upper, lower)
        if where.is_empty:  # one of the two went with a dead end
            continue
        surviving += 1
        assert not _joined_near(result, where, upper, lower), (upper, lower)
        assert not _joined_near(result, _crossing_point(source, upper, lower), upper, lower)
    assert surviving >= 2


def test_circle_bug_is_empty_by_default_and_clean_with_service():
    assert not simplified("circle-bug.osm.gz").network.streets
    net = simplified("circle-bug.osm.gz", service=True).network
    assert net.streets and not any(violations(net).values())


def test_same_input_same_result():
    a = simplify(loaded("monaco.osm.gz"))
    b = simplify(loaded("monaco.osm.gz"))
    assert a.network.streets == b.network.streets
    assert np.array_equal(a.network.xy, b.network.xy)
    assert a.report == b.report


def test_report_counts_every_pass():
    report = simplified("krems.osm.gz").report
    names = [p["pass"] for p in report["passes"]]
    assert names[0] == "input" and names[-1] == "final"
    for p in report["passes"]:
        assert {"street_nodes", "junctions", "streets"} <= set(p)
    assert report["dead_ends_removed"] > 0 and report["clipped_ways"] == 0
    assert simplified("campo-grande.osm.gz").report["clipped_ways"] > 100
    assert next(p for p in report["passes"] if p["pass"] == "roundabouts")["roundabouts"] > 0
    assert next(p for p in report["passes"] if p["pass"] == "merging")["merges"] > 0


@pytest.mark.parametrize("name,service,paths", [("monaco.osm.gz", True, False), ("andorra.osm.pbf", True, True),
                                                ("north-bayreuth.osm.gz", True, True)])
def test_optional_street_classes_keep_the_invariants(name, service, paths):
    net = simplify(load(FIXTURES / name, service=service, paths=paths, context=False).network).network
    assert not any(violations(net).values())


def test_street_lines_are_the_streets_polylines_in_order():
    net = loaded("krems.osm.gz")
    lines = net.street_lines()
    assert len(lines) == len(net.streets)
    for line, street in zip(lines.tolist(), net.streets):
        assert np.array_equal(shapely.get_coordinates(line), net.street_xy(street))
    assert len(net.replace(streets=()).street_lines()) == 0


def test_street_lines_are_made_once_per_network_and_read_only():
    net = loaded("krems.osm.gz")
    lines = net.street_lines()
    assert net.street_lines() is lines  # the engine asks six times a district
    with pytest.raises(ValueError):
        lines[0] = None  # shared: nobody may change them in place
    again = pickle.loads(pickle.dumps(net))
    assert "_street_lines" not in again.__dict__ and shapely.equals(again.street_lines(), lines).all()
    moved = net.replace(xy=net.xy + 1.0)  # a new network makes its own lines
    assert np.allclose(shapely.get_coordinates(moved.street_lines()), shapely.get_coordinates(lines) + 1.0)


def test_total_length_is_measured_once_per_network_and_is_the_sum_street_by_street():
    """A network's length is kept with it (a district's pattern asks the same networks again); it is the very
    sum of its streets' lengths, and a network made from it (other streets, moved nodes) measures its own."""
    from osm_expand.model.geometry import polyline_length

    net = pickle.loads(pickle.dumps(loaded("krems.osm.gz")))
    total = net.total_length()
    assert total == float(sum(polyline_length(net.street_xy(s)) for s in net.streets))
    assert net.__dict__["_total_length"] == total and net.total_length() == total
    fewer = net.replace(streets=net.streets[:10])
    assert fewer.total_length() == float(sum(polyline_length(net.street_xy(s)) for s in net.streets[:10]))
    assert net.replace(xy=net.xy * 2.0).total_length() == pytest.approx(2.0 * total, rel=1e-12)
    added = net.with_new_streets([np.array([[0.0, 0.0], [0.0, 100.0]])], [{}])
    assert added.total_length() == pytest.approx(total + 100.0, abs=1e-6)


def test_new_streets_are_cut_alike_whether_the_segment_keys_were_handed_on_or_made_again():
    """with_new_streets hands its segment keys on to the network it makes (issue 22): a chain of
    additions cuts the new lines where they double a segment exactly as networks made afresh do."""
    net = loaded("krems.osm.gz")
    rng = np.random.default_rng(3)
    chained = fresh = net
    for _ in range(4):
        # lines along existing segments (doubled: cut there), through new points, and back on themselves
        street = net.streets[int(rng.integers(len(net.streets)))]
        along = net.street_xy(street)
        line = np.vstack([along, along[-1] + rng.normal(0, 40, (3, 2)), along[::-1][:2]])
        chained = chained.with_new_streets([line, along], [{}, {}], one_street_per_segment=True)
        fresh = pickle.loads(pickle.dumps(fresh)).with_new_streets([line, along], [{}, {}],
                                                                  one_street_per_segment=True)
        assert "_segment_key_memo" in chained.__dict__
        assert [s.nodes for s in chained.streets] == [s.nodes for s in fresh.streets]
        assert [s.id for s in chained.streets] == [s.id for s in fresh.streets]
    assert len(chained.streets) > len(net.streets)
    assert np.array_equal(chained._segment_keys(), pickle.loads(pickle.dumps(chained))._segment_keys())


def test_match_points_takes_the_nearest_and_the_first_of_equal_ones():
    from osm_expand.model.geometry import match_points

    known = np.array([[0.0, 0.0], [5.0, 5.0], [5.0, 5.0], [5.0005, 5.0], [1e6, 1e6]])
    points = np.array([[5.0004, 5.0], [5.0, 5.0], [0.0, 0.0009], [3.0, 3.0], [5.0001, 5.0]])
    assert match_points(points, known, 1e-3).tolist() == [3, 1, 0, -1, 1]
    assert match_points(points, known[:0], 1e-3).tolist() == [-1] * 5
    # duplicate nodes at one spot far apart in the index: the first, whatever order a tree meets them in
    many = np.random.default_rng(0).uniform(0, 1e4, (20000, 2))
    many[15000] = many[100]
    assert match_points(many[[100, 15000]], many, 1e-3).tolist() == [100, 100]
    assert match_points(many, many, 1e-3)[15000] == 100
