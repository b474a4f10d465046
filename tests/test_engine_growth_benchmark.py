"""benchmarks/engine_growth.py's ``--measures`` line: a NaN value or range (None in ``to_dict``) is printed,
not a TypeError minutes into a run."""
from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parent.parent / "benchmarks" / "engine_growth.py"


def _module():
    spec = importlib.util.spec_from_file_location("engine_growth", _PATH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_off_measures_prints_nan_values_and_ranges_as_na():
    off = _module()._off_measures({"measures": {
        "dead_end_share": {"ok": False, "kind": "scalar", "value": None, "low": 0.1, "high": 0.2},
        "density": {"ok": False, "kind": "scalar", "value": 3.0, "low": None, "high": None},
        "two_core_share": {"ok": False, "kind": "scalar", "value": 0.5, "low": 0.8, "high": 0.9},
        "four_way_share": {"ok": False, "kind": "scalar", "value": 0.3, "low": 0.2, "high": 0.2},
        "three_way_share": {"ok": True, "kind": "scalar", "value": None, "low": None, "high": None}}})
    parts = off.split("; ")
    assert parts[0] == "dead_end_share n/a [0.1–0.2]"
    assert parts[1] == "density n/a [None–None]"
    assert parts[2] == "two_core_share 0.5 [0.8–0.9] (+3.00 widths)"
    assert "in the measure's units" in parts[3]
    assert len(parts) == 4


def test_the_benchmark_sets_a_growth_option_by_its_fields_type():
    module = _module()
    assert module.growth_option("pattern_aim=true") == ("pattern_aim", True)
    assert module.growth_option("pattern_aim=False") == ("pattern_aim", False)
    assert module.growth_option("min_district=12.5") == ("min_district", 12.5)
    assert module.growth_option("sites_tried=7") == ("sites_tried", 7)
    for bad in ("pattern_aim=yes", "no_such_field=1", "sites_tried", "sites_tried=x"):
        with pytest.raises(argparse.ArgumentTypeError):
            module.growth_option(bad)


def test_the_benchmark_reads_a_range_or_a_list_of_run_seeds():
    module = _module()
    assert module.run_seeds("0-5") == [0, 1, 2, 3, 4, 5]
    assert module.run_seeds("3") == [3]
    assert module.run_seeds("0,2,4") == [0, 2, 4]
    for bad in ("a-b", "", "5-2", "1,x"):
        with pytest.raises(argparse.ArgumentTypeError):
            module.run_seeds(bad)


def test_the_benchmark_sets_a_patch_option_on_every_example_era():
    """``--patch-option transplant=false``: every era growing districts with the example pattern gets the field,
    the rest of its options kept; a name that is no PatchOptions field is refused at the command line."""
    from osm_expand.engine.history import load_history
    from synth.patches import PatchOptions

    module = _module()
    assert module.patch_option("transplant=true") == ("transplant", True)
    for bad in ("no_such_field=1", "transplant", "transplant=yes"):
        with pytest.raises(argparse.ArgumentTypeError):
            module.patch_option(bad)
    story = load_history("example")
    changed = module.with_patch_options(story, {"transplant": False})  # on by default: set it off
    patched = [(e, f) for e, f in zip(story.eras, changed.eras) if isinstance(e.options, PatchOptions)]
    assert patched
    for before, after in patched:
        assert not after.options.transplant and before.options.transplant
        assert after.options == PatchOptions(**{**before.options.__dict__, "transplant": False})
