"""A placed engine district finished: missed junctions joined, streets into occupied land taken back (issue 20)."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from osm_expand.engine.growth.minor_streets import GrowthOptions
from osm_expand.engine.growth.stubs import finish_district
from osm_expand.errors import OptionError
from osm_expand.joins import join_dead_ends
from osm_expand.model import City, Origin, network_from_lines
from osm_expand.model.topology import segment_degree

TOWN = [[(-200.0, 0.0), (0.0, 0.0), (400.0, 0.0)]]
#: a block joined to the town at (0, 0); a stem ending 15 m short of the town street (a missed junction); a
#: road out ending at x = 500 against a field taken by the town (x >= 500); another into the open country at y = 300
DISTRICT = [[(0.0, 0.0), (0.0, 50.0)], [(0.0, 50.0), (150.0, 50.0), (300.0, 50.0), (300.0, 100.0), (300.0, 150.0),
                                        (0.0, 150.0), (0.0, 50.0)],
            [(150.0, 50.0), (150.0, 15.0)], [(300.0, 100.0), (420.0, 100.0), (500.0, 100.0)],
            [(150.0, 150.0), (150.0, 300.0)]]
TAKEN = shapely.box(500.0, -100.0, 700.0, 400.0)


def _city() -> City:
    attrs = [{"origin": Origin.SOURCE}] * len(TOWN) + [{"origin": Origin.ENGINE}] * len(DISTRICT)
    return City(network=network_from_lines(TOWN + DISTRICT, attrs), unbuildable=TAKEN)


def _degree(city: City, x: float, y: float) -> int:
    net = city.network
    return int(segment_degree(net.streets, len(net.xy))[int(np.argmin(np.hypot(*(net.xy - (x, y)).T)))])


def _length(city: City) -> float:
    return city.network.total_length()


def test_a_dead_end_short_of_the_town_runs_on_and_the_road_into_taken_land_goes():
    city = _city()
    done, report = finish_district(city, len(TOWN), spacing=100.0, run_on=0.3, trim_blocked=True, year=2030,
                                   era="e")
    assert report.links == 1 and report.trimmed == 1
    assert report.trimmed_m == pytest.approx(200.0)
    assert _degree(done, 150.0, 15.0) == 2  # joined: the town street's tee and the stem
    (link,) = [s for s in done.network.streets if s.origin == Origin.JOIN]
    assert (link.year, link.era) == (2030, "e")
    assert _length(done) == pytest.approx(_length(city) + 15.0 - 200.0)
    assert _degree(done, 300.0, 100.0) == 2  # the road out went back to the block's side
    assert _degree(done, 150.0, 300.0) == 1  # the road into the open country stays
    assert len(done.network.streets[0].nodes) == 4  # the town's way gained the tee's node


def test_off_the_district_is_left_as_placed():
    city = _city()
    done, report = finish_district(city, len(TOWN), spacing=100.0, run_on=0.0, trim_blocked=False)
    assert done is city and (report.links, report.trimmed) == (0, 0)


def test_a_dead_end_beyond_reach_is_not_joined_and_the_towns_streets_are_never_trimmed():
    city = _city()
    done, links = join_dead_ends(city, range(len(TOWN), len(city.network.streets)), reach=10.0)
    assert done is city and links == 0  # 15 m is beyond 10 m
    # the town's street ends against the taken land too: counted from the district's first street, it stays
    town_into = [[(-200.0, 0.0), (0.0, 0.0), (495.0, 0.0)]]
    attrs = [{"origin": Origin.SOURCE}] + [{"origin": Origin.ENGINE}] * len(DISTRICT)
    other = City(network=network_from_lines(town_into + DISTRICT, attrs), unbuildable=TAKEN)
    done, report = finish_district(other, 1, spacing=100.0, run_on=0.0, trim_blocked=True)
    assert report.trimmed == 1 and _degree(done, 495.0, 0.0) == 1


@pytest.mark.parametrize("run_on", [-1.0, float("nan"), float("inf")])
def test_a_run_on_that_is_no_distance_is_refused(run_on):
    with pytest.raises(OptionError, match="district_run_on"):
        GrowthOptions(district_run_on=run_on)
    with pytest.raises(OptionError, match="run_on"):
        finish_district(_city(), len(TOWN), spacing=100.0, run_on=run_on, trim_blocked=False)
