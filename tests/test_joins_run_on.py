"""A district's dead end left just short of a town street runs on to it after the joins (join_to_town's run_on)."""
from __future__ import annotations

import numpy as np
import pytest

from osm_expand.errors import OptionError
from osm_expand.joins import join_to_town
from osm_expand.model import City, Origin, network_from_lines
from osm_expand.model.topology import segment_degree

TOWN = [[(-200.0, 0.0), (0.0, 0.0), (400.0, 0.0)]]
#: a block joined to the town at (0, 0); a stem ending 15 m short of the town street, another 40 m short
DISTRICT = [[(0.0, 0.0), (0.0, 50.0)], [(0.0, 50.0), (150.0, 50.0), (300.0, 50.0), (300.0, 150.0), (0.0, 150.0),
                                        (0.0, 50.0)],
            [(150.0, 50.0), (150.0, 15.0)], [(300.0, 150.0), (350.0, 150.0), (350.0, 40.0)]]


def _joined(run_on: float) -> tuple[City, np.ndarray]:
    attrs = [{"origin": Origin.SOURCE}] * len(TOWN) + [{"origin": Origin.GROWN}] * len(DISTRICT)
    net = network_from_lines(TOWN + DISTRICT, attrs)
    new = list(range(len(TOWN), len(net.streets)))
    city, _ = join_to_town(City(network=net), new, reach=200.0, spread=200.0, most=1, run_on=run_on)
    out = city.network
    return city, segment_degree(out.streets, len(out.xy))


def _node(city: City, x: float, y: float) -> int:
    return int(np.argmin(np.hypot(*(city.network.xy - (x, y)).T)))


def test_off_a_district_joined_at_its_most_places_keeps_the_end_short_of_the_town():
    city, degree = _joined(0.0)
    assert degree[_node(city, 150.0, 15.0)] == 1
    assert not any(s.origin == Origin.JOIN for s in city.network.streets)


def test_on_the_end_within_reach_runs_on_to_the_town_street_and_the_farther_one_stays():
    city, degree = _joined(30.0)  # 0.3 spacings of 100 m
    assert degree[_node(city, 150.0, 15.0)] == 2
    assert degree[_node(city, 350.0, 40.0)] == 1
    (link,) = [s for s in city.network.streets if s.origin == Origin.JOIN]
    ends = city.network.xy[[link.nodes[0], link.nodes[-1]]]
    assert sorted(map(tuple, ends.round(6).tolist())) == [(150.0, 0.0), (150.0, 15.0)]
    town = city.network.streets[0]
    assert _node(city, 150.0, 0.0) in town.nodes  # a tee: the town's way gained the node


@pytest.mark.parametrize("run_on", [-1.0, float("nan"), float("inf")])
def test_a_run_on_reach_that_is_no_distance_is_refused(run_on):
    with pytest.raises(OptionError, match="run_on"):
        _joined(run_on)
