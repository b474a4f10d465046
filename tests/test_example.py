"""The example model: Gravelius levels, per-junction records and statistics."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from osm_expand import cli
from osm_expand.model import network_from_lines
from simplify.example import build_example
from simplify.hierarchy import gravelius_levels
from simplify.statistics import example_statistics, orientation_entropy, orientation_order
from tests.conftest import FIXTURES, simplified


def comb():
    """A 600 m main street crossed by three 200 m side streets; a lane crosses the first side street."""
    main = [(0, 0), (100, 0), (300, 0), (500, 0), (600, 0)]
    sides = [[(x, -100), (x, 0), (x, 100)] for x in (100, 300, 500)]
    lane = [(50, 50), (100, 50), (150, 50)]
    sides[0] = [(100, -100), (100, 0), (100, 50), (100, 100)]
    return [main] + sides + [lane]


def test_gravelius_levels_follow_crossings():
    assert gravelius_levels(network_from_lines(comb())).tolist() == [0, 1, 1, 1, 2]


def test_each_component_has_its_own_level_zero():
    far = [[(5000, 0), (5100, 0), (5300, 0)], [(5100, -50), (5100, 0), (5100, 50)]]
    levels = gravelius_levels(network_from_lines(comb() + far)).tolist()
    assert levels == [0, 1, 1, 1, 2, 0, 1]


def test_ties_go_to_the_more_important_class():
    lines = [[(0, 0), (100, 0), (200, 0)], [(100, -100), (100, 0), (100, 100)]]
    net = network_from_lines(lines, [{"highway": "residential"}, {"highway": "primary"}])
    assert gravelius_levels(net).tolist() == [1, 0]


def test_junction_records_hold_both_streets_statistics():
    ex = build_example(network_from_lines(comb()))
    j = int(np.flatnonzero((ex.xy == (300, 0)).all(axis=1))[0])
    assert sorted(ex.level[j].tolist()) == [0, 1]
    main = list(ex.level[j]).index(0)
    # main street junctions at x = 100, 300, 500: spacing 200, 200; straight
    assert ex.length_mean[j, main] == pytest.approx(200.0)
    assert ex.angle_mean[j, main] == pytest.approx(0.0)
    assert ex.degree[j] == 4 and ex.slots[j] == 0


def test_street_statistics_by_hand():
    # junctions at 0, 100 and 300 along x, then a 90 degree left turn of 100 m
    street = [(0, 0), (100, 0), (300, 0), (300, 100)]
    crossers = [[(x, -10), (x, 0), (x, 10)] for x in (100, 300)]
    crossers.append([(-10, 0), (0, 0), (0, 10)])
    crossers.append([(290, 100), (300, 100), (310, 100)])
    ex = build_example(network_from_lines([street] + crossers))
    s = ex.streets[0]
    assert s.spacing.tolist() == pytest.approx([100.0, 200.0, 100.0])
    assert s.turning.tolist() == pytest.approx([0.0, 90.0])
    assert s.tortuosity.tolist() == pytest.approx([1.0, 1.0, 1.0])


def test_degree_three_and_two():
    t_junction = [[(0, 0), (100, 0), (200, 0)], [(100, 0), (100, 100)]]
    ex = build_example(network_from_lines(t_junction))
    j = int(np.flatnonzero((ex.xy == (100, 0)).all(axis=1))[0])
    assert ex.degree[j] == 3 and ex.slots[j] == 1
    corner = [[(0, 0), (100, 0)], [(100, 0), (100, 100)]]
    ex = build_example(network_from_lines(corner))
    assert ex.degree.tolist() == [2] and ex.slots.tolist() == [2]


def test_orientation_entropy_of_a_grid_and_of_all_directions():
    grid = np.array([[[0, 0], [100, 0]], [[0, 0], [0, 100]]], dtype=float)
    assert orientation_entropy(grid) == pytest.approx(math.log(4))
    assert orientation_order(orientation_entropy(grid)) == pytest.approx(1.0)
    angles = np.radians(np.arange(0, 180, 10))
    spokes = np.stack([np.zeros((18, 2)), np.column_stack([np.sin(angles), np.cos(angles)])], axis=1)
    assert orientation_entropy(spokes) == pytest.approx(math.log(36))


def test_statistics_of_a_grid_by_hand():
    # 3 x 3 lines, 100 m apart: 4 corners (2-way), 4 border T (3-way), 1 crossing (4-way)
    lines = [[(0, y), (100, y), (200, y)] for y in (0, 100, 200)]
    lines += [[(x, 0), (x, 100), (x, 200)] for x in (0, 100, 200)]
    stats = example_statistics(build_example(network_from_lines(lines)))
    assert stats["junctions"] == 9 and stats["streets"] == 6
    assert stats["three_way_share"] == pytest.approx(4 / 9, abs=1e-4)
    assert stats["four_way_share"] == pytest.approx(1 / 9, abs=1e-4)
    assert stats["total_length_km"] == pytest.approx(1.2)
    assert stats["junction_spacing_m"]["mean"] == pytest.approx(100.0)
    assert stats["orientation_order"] == pytest.approx(1.0)


def test_dead_ends_are_recorded_per_level():
    result = simplified("krems.osm.gz")
    ex = build_example(result.network, result.dead_ends)
    assert ex.dead_ends_per_level and all(v["per_junction"] >= 0 for v in ex.dead_ends_per_level.values())
    assert sum(v["per_junction"] for v in ex.dead_ends_per_level.values()) > 0


def test_stats_command_agrees_on_a_town_and_its_outputs(tmp_path, capsys):
    assert cli.main(["stats", str(FIXTURES / "krems.osm.gz"), "--json", "-q"]) == 0
    town = json.loads(capsys.readouterr().out)
    for suffix in (".osm", ".geojson"):
        out = tmp_path / f"k{suffix}"
        assert cli.main(["simplify", str(FIXTURES / "krems.osm.gz"), "-o", str(out), "-q"]) == 0
        assert cli.main(["stats", str(out), "--json", "-q"]) == 0
        again = json.loads(capsys.readouterr().out)
        for key in ("junctions", "streets", "levels", "three_way_share", "four_way_share", "orientation_entropy"):
            assert again[key] == pytest.approx(town[key], rel=1e-3), key
    assert 0 < town["dead_end_share"] < 1 and town["levels"] >= 3


def test_stats_rejects_bad_input(tmp_path, capsys):
    bad = tmp_path / "x.geojson"
    bad.write_text("{not json")
    assert cli.main(["stats", str(bad)]) == 2
    assert "not a readable GeoJSON" in capsys.readouterr().err
