"""One positive-option check (issue 23): every options dataclass whose fields must be positive refuses a zero
through :func:`osm_expand.model.options.require_positive`, in the same words (``Class.field must be positive,
got value``), and no module writes that check again."""
from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

from osm_expand.errors import InputError
from osm_expand.model.options import require_positive

ROOT = Path(__file__).resolve().parent.parent


#: ``module:Class.field`` of options that must be positive, a few of each class that checks them.
POSITIVE = ["osm_expand.measures:MeasureOptions.node_precision", "osm_expand.measures:MeasureOptions.orientation_bins",
            "osm_expand.growth_fidelity:GrowthFidelityOptions.ring_width",
            "osm_expand.growth_fidelity:GrowthFidelityOptions.min_piece_area",
            "osm_expand.engine.buildout.calibration:CalibrationOptions.town_cell",
            "osm_expand.engine.buildout.calibration:CalibrationOptions.default_coverage",
            "osm_expand.engine.buildout.year:BuildoutOptions.resolution",
            "osm_expand.engine.buildout.landuse_types:LandUseOptions.goal_scale",
            "osm_expand.engine.buildout.landuse_types:LandUseOptions.min_calibration_coverage",
            "osm_expand.engine.buildout.economy:EconomyOptions.storey_height",
            "osm_expand.engine.buildout.economy:EconomyOptions.margin_truncation",
            "osm_expand.engine.traffic.trade:TradeOptions.o2",
            "osm_expand.engine.traffic.trips:TripOptions.decay_length",
            "osm_expand.engine.traffic.trips:TripOptions.batch_sources",
            "osm_expand.engine.roads.routing:RoutingOptions.window_margin",
            "osm_expand.engine.roads.routing:RoutingOptions.growth_share",
            "osm_expand.engine.roads.routing:RoutingOptions.turn_width",
            "osm_expand.engine.roads.road_types:MajorRoadOptions.smoothing_step"]


@pytest.mark.parametrize("where", POSITIVE)
def test_a_value_not_positive_where_an_option_must_be_positive_is_refused_in_the_same_words(where):
    module, _, attribute = where.partition(":")
    class_name, _, name = attribute.partition(".")
    cls = getattr(importlib.import_module(module), class_name)
    cls()  # the defaults pass
    for bad in (0, -1.5, float("nan")):
        with pytest.raises(InputError, match=rf"^{class_name}\.{name} must be positive, got {re.escape(str(bad))}$"):
            cls(**{name: bad})


def test_require_positive_names_the_class_and_the_field():
    class Spacing:
        step = 20.0
        margin = 0.0

    require_positive(Spacing(), ("step",))
    with pytest.raises(InputError, match=r"^Spacing\.margin must be positive, got 0\.0$"):
        require_positive(Spacing(), ("step", "margin"))


def test_no_module_writes_the_positive_check_again():
    """The check over an options' own fields (``getattr(self, key) > 0`` with its own message) lives only in
    ``osm_expand/model/options.py``."""
    own_check = re.compile(r"getattr\(self, \w+\) > 0|must be (positive|> 0), got \{(getattr\(self|self\.)")
    found = [str(path.relative_to(ROOT)) for package in ("osm_expand", "simplify")
             for path in sorted((ROOT / package).rglob("*.py"))
             if path != ROOT / "osm_expand" / "model" / "options.py" and own_check.search(path.read_text("utf-8"))]
    assert found == []
