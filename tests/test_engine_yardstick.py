"""The town's neighbourhoods as the growth verdict pools them (:class:`DistrictYardstick`, issue 20): what a named
pattern's era aims its dead-end and 2-core shares at (``GrowthOptions.pattern_aim``)."""
from __future__ import annotations

import numpy as np
import shapely

from osm_expand.engine.growth.yardstick import JUDGED, DistrictYardstick, growth_lines
from osm_expand.joins import add_streets
from osm_expand.model import Origin, Status
from tests.test_engine_districts import town

ATTRS = {"highway": "residential", "hierarchy": 9, "origin": Origin.ENGINE, "status": Status.PLANNED,
         "year": 2000, "era": "now", "bridge": False, "layer": 0}


def _shares(counts: np.ndarray) -> tuple[float, float]:
    """Dead-end share and 2-core share of :meth:`DistrictYardstick.measured`'s counts."""
    length, _, dead, counted, core = counts
    return dead / counted, core / length


def test_the_towns_own_neighbourhood_lies_nearer_its_medians_than_a_comb():
    """The yardstick on Krems: the town's own streets around a dense junction lie nearer the neighbourhoods'
    median dead-end and 2-core shares than a comb of dead-end streets hung on one street, which is far off both."""
    city, learned = town("krems.osm.gz")
    stick = DistrictYardstick.of_town(city, seed=0)
    spacing = learned.example.spacing
    # the town's streets in one of its own neighbourhood discs, open where they leave it
    from osm_expand.fidelity import real_parts

    disc = real_parts(stick.town, 0.4e6, n=1, rng=1)[0]
    cut = shapely.get_parts(shapely.intersection(stick.town.geoms, disc))
    inside = [np.asarray(g.coords) for g in cut if g.geom_type == "LineString" and g.length > 0]
    ends = np.array([xy for line in inside for xy in (line[0], line[-1])])
    rim = ends[shapely.distance(shapely.points(ends), disc.boundary) < 1.0]
    own, medians = stick.aim(inside, rim)
    assert len(medians) == len(JUDGED) and np.isfinite(medians).all()
    own_dead, own_core = _shares(own)
    # a comb: a spine with teeth a spacing long, in the fields, open at the spine's one end
    x0, y0 = city.network.xy.min(axis=0) - 2000.0
    spine = np.array([[x0, y0], [x0 + 20 * spacing, y0]])
    teeth = [np.array([[x0 + k * spacing, y0], [x0 + k * spacing, y0 + spacing]]) for k in range(1, 20)]
    comb, comb_medians = stick.aim([spine, *teeth], spine[:1])
    comb_dead, comb_core = _shares(comb)
    # the comb is a tree: far more dead ends and far less loop length than the town's neighbourhoods and its own
    assert comb_dead > comb_medians[1] + 0.2 and comb_core < comb_medians[2] - 0.5
    assert abs(own_dead - medians[1]) < abs(comb_dead - comb_medians[1])
    assert abs(own_core - medians[2]) < abs(comb_core - comb_medians[2])
    assert len(stick.discs) >= 1  # measured once per bin of area, kept for the run


def test_the_growth_is_the_engines_streets_open_where_they_meet_the_others():
    city, _ = town("krems.osm.gz")
    net = city.network
    a = net.xy[net.streets[0].nodes[0]]
    grown = add_streets(city, [np.array([a, a + [0.0, 50.0], a + [50.0, 50.0]])], [ATTRS])
    lines, open_points = growth_lines(grown)
    assert len(lines) == 1 and np.allclose(open_points, [a])


def test_pooled_discs_narrow_the_spread():
    """Two pieces of a bin pool two discs a part: the spread of the pooled dead-end and 2-core shares over the
    parts is no wider than one disc's (the verdict's pooled references, issue 20)."""
    city, _ = town("krems.osm.gz")
    stick = DistrictYardstick.of_town(city, seed=0)
    one, two = stick.pooled([0.3e6]), stick.pooled([0.3e6, 0.3e6])
    assert len(stick.discs) == 1
    spread = np.nanpercentile(one, 90, axis=0) - np.nanpercentile(one, 10, axis=0)
    pooled = np.nanpercentile(two, 90, axis=0) - np.nanpercentile(two, 10, axis=0)
    assert (pooled <= spread + 1e-9).sum() >= 2
