"""Knots of a water polygon's skeleton that no reading makes into channels (issue 22): the
water round the place the reading failed at is made a lake, reported, and the water read
again (``riverflow/gis/water.py``, ``_knot_lake``)."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

import riverflow as rf
import riverflow.gis.water as water_mod
from tests.gis.conftest import ORIGIN, UTM, require_gis

require_gis()


def survey_river(seed: int):
    """``benchmarks/survey_water.py``'s river polygon of ``seed`` (islands that may cross a
    bank), relative to ORIGIN: the survey's own function, so the test's seed is the
    survey's."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "survey_water.py"
    spec = importlib.util.spec_from_file_location("survey_water", path)
    survey = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(survey)
    return survey.river(seed, inside=False)[0]


def write(path, geom):
    import pyogrio.raw

    pyogrio.raw.write(str(path), np.array([shapely.to_wkb(shapely.transform(
        geom, lambda c: c + ORIGIN))], dtype=object), [], [], driver="GPKG", crs=UTM,
        geometry_type=geom.geom_type)
    return path


def test_a_knot_no_reading_builds_is_made_a_lake(tmp_path, monkeypatch):
    # survey seed 52: a channel between the bank and a stub on the data's edge whose banks
    # the builder does not find ("no banks found across its middle") in every reading
    path = write(tmp_path / "w52.gpkg", survey_river(52))
    monkeypatch.setattr(water_mod, "MAX_KNOTS", 0)
    with pytest.raises(rf.GraphError, match="no banks found across its middle, near"):
        rf.read_water(path, origin_m=ORIGIN).build()
    monkeypatch.undo()
    b = rf.read_water(path, origin_m=ORIGIN)
    graph = b.build()
    knots = [r for r in b.report.repairs if r.feature.startswith("knot ")]
    assert len(knots) == 1 and "no banks found" in knots[0].what, b.report.repairs
    assert "knots" in b.report.derived
    assert b.report.derived["direction"] == "as the water ran before its knots were made lakes"
    (k,) = graph.lakes()
    x, y = map(float, knots[0].what.split("round (")[1].split(")")[0].split(", "))
    lake = b._lakes[0].polygon
    assert lake.distance(shapely.Point(x, y)) < 1.0          # the lake is where it failed
    assert lake.area < 0.5 * b.water.area                    # the rest are channels
    assert b._branches and all(q > 0 for q in b.discharges_m2s)
    # no water is lost: a piece the lake cut off too short for a channel joins it
    assert not any("left out" in r.what for r in b.report.repairs), b.report.repairs
