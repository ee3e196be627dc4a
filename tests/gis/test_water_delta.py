"""A delta reaching the sea (issue 22, RivGraph's Colville mask): open water wider than
many channel widths that reaches the data's edge is a still lake the distributaries end in
(``report.derived["open water"]``): their mouths are cut straight across, the ends on its
shore are the outlets, with or without ``outlets=``."""
from __future__ import annotations

import numpy as np
import shapely

import riverflow as rf
from tests.gis.conftest import ORIGIN, require_gis
from tests.gis.test_water import write_mask, write_polygons

require_gis()

SEA = shapely.intersection(shapely.Point(400.0, 1500.0).buffer(600.0),
                          shapely.box(-300.0, 0.0, 1100.0, 1500.0))
"""The sea: a bay 1 200 m wide cut by the data's top edge [m]."""
RIVER = shapely.LineString([(400, 0), (400, 500)]).buffer(20, cap_style="flat")
ARMS = shapely.union(shapely.LineString([(400, 480), (150, 950)]).buffer(15, cap_style="flat"),
                     shapely.LineString([(400, 480), (650, 950)]).buffer(15, cap_style="flat"))
DELTA = shapely.union_all([SEA, RIVER, ARMS])
"""A river entering at the data's bottom edge, parting into two distributaries that open
into the sea."""


def flow_at(builder, graph, pts):
    shift = ORIGIN - np.asarray(builder.report.origin_m or (0.0, 0.0))
    return rf.FlowField(graph).query(np.asarray(pts, float) + shift)


def check_delta(b, graph):
    assert "open water" in b.report.derived and len(graph.lakes()) == 1
    assert "terminal lakes" in b.report.derived
    status, v = flow_at(b, graph, [(400, 250), (230, 800), (570, 800), (400, 1250)])
    assert (status == rf.FlowStatus.INSIDE).all()
    assert v[0, 1] > 0.0 and v[1, 1] > 0.0 and v[2, 1] > 0.0      # downstream, to the sea
    assert np.hypot(*v[3]) < 1e-6                                 # the sea is still


def test_a_delta_into_the_sea_ends_on_open_water(tmp_path):
    """No inlet or outlet given: the river comes in at the bottom, its two arms leave into
    the sea (before: the longest path from the narrower end, into the sea and back)."""
    b = rf.read_water(write_polygons(tmp_path / "d.gpkg", [DELTA]))
    check_delta(b, b.build())


def test_an_outlet_given_in_the_sea_is_the_sea(tmp_path):
    b = rf.read_water(write_polygons(tmp_path / "d.gpkg", [DELTA]),
                      outlets=[tuple(ORIGIN + (400, 1250))])
    check_delta(b, b.build())
    assert any("open water" in n for n in b.report.notes)


def test_a_mask_with_an_empty_border_ends_at_its_water(tmp_path):
    """RivGraph's masks have a border of empty cells round the water: the sea reaching the
    water cells' bounding box reaches the data's edge."""
    path = write_mask(tmp_path / "d.tif", DELTA, 5.0, bounds=(-300.0, -100.0, 1100.0, 1600.0))
    b = rf.read_water(path)
    check_delta(b, b.build())
