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


def test_mouths_side_by_side_meet_through_the_sea():
    """Two distributaries either side of an island whose tip nearly reaches the sea: their
    axes' ends on the shore lie nearer than half their widths together (a skeleton's widths
    at a mouth are the flared mouth's, Colville's many such mouths), yet they do not miss a
    junction: the sea joins them (before: "branches 'north' and 'south' do not meet")."""
    from riverflow.hydro.builder import RiverNetworkBuilder

    sea = shapely.box(0, -300, 400, 300)
    water = shapely.difference(
        shapely.union(shapely.box(-600, -30, -250, 30),
                      shapely.Polygon([(-260, -70), (-100, -70), (0, -88), (0, 88), (-100, 70),
                                       (-260, 70)])),
        shapely.Polygon([(-200, -8), (-2, -2), (-2, 2), (-200, 8)]))
    b = RiverNetworkBuilder()
    b.add_branch([(-600, 0), (-260, 0)], 60.0, discharge_m2s=5.0, name="river")
    for side, name in ((1.0, "north"), (-1.0, "south")):
        b.add_branch([(-260, 0), (-200, 40 * side), (-100, 40 * side), (0, 45 * side)],
                     [62.0, 62.0, 62.0, 100.0], name=name)
    b.set_water_area(water)
    b.add_lake(sea)
    graph = b.build()
    assert b.terminal_lakes == [0]
    status, v = rf.FlowField(graph).query(np.array([[-400.0, 0.0], [-150.0, 40.0],
                                                   [-150.0, -40.0], [200.0, 0.0]]))
    assert (status == rf.FlowStatus.INSIDE).all()
    assert (v[:3, 0] > 0.01).all() and np.abs(v[3]).max() < 1e-6


def test_a_mouth_flaring_into_a_bay_is_cut_along_the_sea():
    """A 60 m river flaring over its last 150 m into a bay 300 m wide on the sea (a terminal
    lake): its end, capped off the sea's shore, is cut along that shore, however much wider
    than its channel (before: "does not reach across the water to its banks"); the bay stays
    water, the river runs, the sea is still."""
    from riverflow.hydro.areas import water_polygon
    from riverflow.hydro.builder import RiverNetworkBuilder

    sea = shapely.box(0, -400, 500, 400)
    water = shapely.union(shapely.box(-800, -30, -140, 30),
                          shapely.Polygon([(-150, -30), (0, -150), (0, 150), (-150, 30)]))
    b = RiverNetworkBuilder()
    b.add_branch([(-800, 0), (-60, 0), (0, 0)], [60.0, 60.0, 200.0], discharge_m2s=5.0)
    b.set_water_area(water)
    b.add_lake(sea)
    graph = b.build()
    assert b.terminal_lakes == [0]
    status, v = rf.FlowField(graph).query(np.array([[-400.0, 0.0], [-60.0, 0.0], [200.0, 0.0]]))
    assert (status == rf.FlowStatus.INSIDE).all()
    assert v[0, 0] > 0.01 and v[1, 0] > 0.01 and np.abs(v[2]).max() < 1e-6
    # only the gap along the shore (a tolerance, 0.25 m, over the bay's 300 m) is left out
    gone = shapely.difference(shapely.union(water, sea), water_polygon(graph))
    assert gone.area < 0.3 * 300.0


def test_a_creek_ending_beside_the_sea_is_not_drawn_across_the_land(tmp_path):
    """A creek off a distributary ends in a round pocket 12 m of land short of the sea (a
    bar a mask's cell or two wide): its dead end is not drawn on to the sea's shore over
    that land (before: drawn on, its water fed from the sea into the delta, "… form a loop
    that flows back into itself"); the delta builds, the sea stays still."""
    c, u = np.array([400.0, 1500.0]), np.array([0.6247, -0.7809])
    pocket = c + (600.0 + 12.0 + 25.0) * u          # the sea: 600 m round c
    creek = shapely.union(shapely.LineString([(560, 780), pocket]).buffer(10, cap_style="flat"),
                          shapely.Point(pocket).buffer(25))
    b = rf.read_water(write_polygons(tmp_path / "d.gpkg", [shapely.union(DELTA, creek)]))
    graph = b.build()
    check_delta(b, graph)
    status, _ = flow_at(b, graph, [0.5 * (np.array([560.0, 780.0]) + pocket)])
    assert status[0] == rf.FlowStatus.INSIDE


def test_a_side_channel_leaving_a_mouths_bay_is_led_into_the_mouth():
    """A side channel whose axis starts in the flared bay of a wider channel's mouth on the
    open water, its start nearer the mouth's end than half their widths together (the
    skeleton puts no point on a mouth, so their axes need not meet: Colville's east mouths),
    is led on into the mouth's channel, which is split there, half the mouth's width back
    from the sea or more (a junction: a distributary, not a source beside the mouth)."""
    from riverflow.gis.rivers import RiverImport
    from riverflow.gis.water import _Channel, _lead_into_mouths, _Network

    bay = shapely.Polygon([(-50, 0), (50, 0), (50, 600), (300, 1000), (-300, 1000), (-50, 600)])
    water = shapely.union(bay, shapely.box(150, 760, 1000, 840))
    sea = shapely.box(-400, 1000, 400, 1400)
    main = _Channel([(0, 0), (0, 600), (0, 1000)], [100.0, 120.0, 600.0], "skeleton", 0, 1,
                    "main")
    side = _Channel([(250, 800), (600, 800), (1000, 800)], [200.0, 80.0, 80.0], "skeleton",
                    2, 3, "side")
    net = _Network(water, [], [main, side], np.array([(0, 0), (0, 1000), (250, 800),
                                                       (1000, 800)], float))
    net.outlets = {1}
    report = RiverImport("x", "y", 1, None, None)
    _lead_into_mouths(net, report, sea, 0.25)
    assert len(net.channels) == 3 and net.degree().tolist().count(3) == 1
    j = net.nodes[int(np.flatnonzero(net.degree() == 3)[0])]
    assert np.allclose(j, (0, 700))                   # half the mouth's 600 m back
    assert np.allclose(side.points[0], j) and side.a == main.b
    assert any("led on" in r.what for r in report.repairs)
    assert len(net.outlets) == 1 and np.allclose(net.nodes[next(iter(net.outlets))], (0, 1000))


def test_a_channel_beside_a_point_of_land_at_the_open_edge_joins_the_reach():
    """A 90 m channel opening into a 250 m reach beside the reach's open end, a 60 m point
    of land between it and the data's edge (Colville's channel 80, beside the sea): the
    point's shore lies within a quarter of the water's mean width (608 m: wide water
    upstream) of the edge, but behind the land, so it stays a bank and the channel's axis
    runs up its middle into the reach's (before: no outline point on it, the channel's axis
    stopped short, cut off from the reach's, and was left out)."""
    from riverflow.gis.water import skeleton

    water = shapely.union_all([shapely.box(-3000, 600, 1000, 850),      # the reach, open east
                               shapely.box(850, -1500, 940, 600),       # the channel
                               shapely.box(-4500, -3000, -3000, 850)])  # wide water upstream
    chains, nodes, collapsed = skeleton(water, 0.25, shapely.box(-4600, -3100, 1000, 950))
    assert collapsed is None and len(chains) == 3
    top = shapely.LineString([(850, 560), (940, 560)])
    crossing = [c for c in (shapely.LineString(p).intersection(top) for p, _, _, _ in chains)
                if not c.is_empty]
    assert len(crossing) == 1 and abs(crossing[0].x - 895.0) < 10.0     # the channel's middle
    deg = np.bincount([n for _, _, a, b in chains for n in (a, b)], minlength=len(nodes))
    ends = nodes[deg == 1]
    assert ((ends[:, 0] > 990.0) & (ends[:, 1] > 600.0)).sum() == 1   # the reach's open end
    assert ((ends[:, 0] > 800.0) & (ends[:, 1] < -1000.0)).sum() == 1   # the channel's dead end


def test_each_piece_of_the_open_edge_keeps_its_own_channels_end():
    """Two pieces of the open edge either side of a point of land (Colville's mouths at
    (2500, 16800)): the west piece keeps the free end nearest it, not a wider channel's end
    on the east piece whose inscribed circle reaches it too (before: the west mouth's axis
    was pruned, its water a shore no branch runs along)."""
    from riverflow.gis.water import _open_ends

    west = shapely.LineString([(2277, 16808), (2688, 16857)])
    east = shapely.LineString([(2751, 16770), (3348, 17493)])
    xy = np.array([(2700, 16000), (2492, 16793), (2919, 16965), (3055, 17129)], float)
    radius = np.array([300.0, 195.0, 294.0, 438.0])
    nbr = [{1: 1.0, 2: 1.0, 3: 1.0}, {0: 1.0}, {0: 1.0}, {0: 1.0}]
    keep = _open_ends(nbr, xy, radius, shapely.MultiLineString([west, east]), None, 52.0)
    assert keep[1] and keep[3]


def test_a_seas_spike_of_no_width_is_no_edge():
    """A sea's ring may go out along a line and straight back (a difference left one 409 m
    into one of Colville's mouths; as the data's edge it cut the mouth's channel short of
    its water): such spikes go, the rest of the ring stays."""
    from riverflow.gis.water import _without_spikes

    sea = shapely.Polygon([(0, 0), (4, 0), (4, 2), (2, 2), (1, 3.5), (2 + 1e-12, 2), (0, 2)])
    clean = _without_spikes(sea, 1e-9)
    assert clean.equals(shapely.box(0, 0, 4, 2)) and len(clean.exterior.coords) == 6
    assert _without_spikes(shapely.box(0, 0, 4, 2), 1e-9).equals(shapely.box(0, 0, 4, 2))


def test_a_reservoir_that_only_touches_the_waters_box_is_no_sea(tmp_path):
    """A 40 m river through a round reservoir 600 m across, the widest water, in a polygon
    file of its own: the reservoir touches the water's bounding box above and below (its
    outline leaves the box at once; a sea's runs along the data's edge, SEA_CUT_RADII) and was
    read as open water, both rivers running into it. The river runs one way through it, in
    a polygon file and in a mask whose border is empty."""
    water = shapely.union(shapely.LineString([(0, 500), (2000, 500)]).buffer(20, cap_style="flat"),
                          shapely.Point(1000, 500).buffer(300, quad_segs=32))
    for path in (write_polygons(tmp_path / "reservoir.geojson", [water]),
                 write_mask(tmp_path / "reservoir.tif", water, 4.0,
                            bounds=(-40.0, 160.0, 2040.0, 840.0))):
        b = rf.read_water(path)
        graph = b.build()
        assert "open water" not in b.report.derived, path
        status, v = flow_at(b, graph, [(300, 500), (1000, 500), (1700, 500)])
        assert (status == rf.FlowStatus.INSIDE).all()
        assert len(set(np.sign(v[:, 0]))) == 1 and (np.abs(v[:, 0]) > 0.1).all(), v


def test_a_mouth_cut_obliquely_by_the_sea_ends_its_axis_at_its_middle():
    """A 240 m channel of a delta (Wax Lake's, from a map's water colour) whose mouth the
    sea cuts obliquely, 483 m along the cut: the spur of the skeleton into the mouth's
    eastern corner, wide for want of outline points by the cut, was taken as the axis's end
    (66 m short of the mouth, 146 m from its middle; "its free end does not reach across
    the water to its banks"). The axis runs out to the mouth near its middle."""
    from riverflow.gis.water import skeleton

    water = shapely.Polygon([(886, 405), (964, 175), (969, 72), (494, 158), (544, 329),
                             (351, 674), (286, 739), (216, 900), (434, 900), (441, 855),
                             (536, 837), (695, 674), (817, 443)])
    # the data's extent less the sea (its shore the mouth's cut), cut off at the top
    frame = shapely.Polygon([(969, 62), (969, 72), (494, 158), (466, 62), (416, 45),
                             (214, 126), (170, 196), (0, 15), (0, 900), (1100, 900),
                             (1100, 0), (994, 0)])
    chains, _, _ = skeleton(water, 9.5, frame)
    mouth = shapely.LineString([(969, 72), (494, 158)])
    end = min((p[i] for p, _, _, _ in chains for i in (0, -1)),
              key=lambda e: mouth.distance(shapely.Point(e)))
    assert mouth.distance(shapely.Point(end)) < 1.0
    assert mouth.interpolate(0.5, normalized=True).distance(shapely.Point(end)) < 30.0
