"""PatchOptions.roads_out_open: whether the district's topology reads a road out on the site's edge as a street
running on (the pipeline's district) or as the dead end it is in the fields (the engine's growth)."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from osm_expand.errors import OptionError
from osm_expand.model import network_from_lines
from synth.patches import PatchOptions
from synth.patches.topology import _Aim, _more_dead_ends, _roads_out

# a ladder: two rails and three rungs, plus a street whose cut end (100, 120) was teed onto the far rail
RUNGS = [[(x, 0.0), (x, 200.0)] for x in (0.0, 200.0, 400.0)]
STEM = [[(100.0, 0.0), (100.0, 120.0)], [(100.0, 120.0), (100.0, 200.0)]]  # the second is the tee
NET = network_from_lines([[(0.0, 0.0), (100.0, 0.0), (200.0, 0.0), (400.0, 0.0)],
                          [(0.0, 200.0), (100.0, 200.0), (200.0, 200.0), (400.0, 200.0)], *RUNGS, *STEM])
TEES = [(np.array([100.0, 120.0]), np.array([100.0, 200.0]))]
FAR = shapely.LineString([(5000, 5000), (5100, 5000)])
#: the site's edge passing through the tee's cut end: there the cul-de-sac would be a road out
EDGE = shapely.LineString([(50.0, 120.0), (150.0, 120.0)])


def test_a_tee_whose_cut_end_is_on_the_edge_stays_while_roads_out_are_open():
    kept = _more_dead_ends(NET, TEES, FAR, EDGE, 100.0, PatchOptions(), _Aim(0.25, 0.5))
    assert len(kept.streets) == len(NET.streets)


def test_with_roads_out_closed_no_edge_is_counted_and_the_tee_is_taken_back_for_a_cul_de_sac():
    closed = PatchOptions(roads_out_open=False)
    assert _roads_out(EDGE, closed) is None and _roads_out(EDGE, PatchOptions()) is EDGE
    taken = _more_dead_ends(NET, TEES, FAR, _roads_out(EDGE, closed), 100.0, closed, _Aim(0.25, 0.5))
    assert len(taken.streets) == len(NET.streets) - 1
    assert PatchOptions().roads_out_open  # the pipeline's district keeps its roads out open by default


def test_roads_out_open_is_a_boolean_not_a_string_a_history_gave():
    with pytest.raises(OptionError, match="roads_out_open"):
        PatchOptions(roads_out_open="false")  # type: ignore[arg-type]
