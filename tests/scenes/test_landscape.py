"""rf.landscape on a graph: the branches it derives from the graph's axes."""
from __future__ import annotations

import numpy as np
import shapely

import riverflow as rf
from riverflow.scenes.flight import main_centerline
from riverflow.scenes.layout import network_length_m


def test_a_graphs_main_river_is_its_longest_path_and_never_jumps():
    scene = rf.default_scene(seed=0)
    land = rf.landscape(scene.graph, seed=0)
    main = [b for b in land.branches if b.kind == "main"]
    others = [b for b in land.branches if b.kind != "main"]
    assert main and others                     # the tributary and the island arms are not
    for up, down in zip(main, main[1:]):       # one after the other, junction to junction
        assert up.end_junction >= 0 and up.end_junction == down.start_junction
    line = main_centerline(land)
    steps = np.linalg.norm(np.diff(line, axis=0), axis=1)
    assert steps.max() <= 10.0 + 1e-6, steps.max()     # no jump between branches
    # the built-in scene's main river runs across its 4 km: so does the graph's longest path
    assert network_length_m(main) > 3500.0
    assert np.linalg.norm(line[-1] - line[0]) > 2000.0


def test_a_narrow_creek_is_resampled_finer_than_it_is_wide():
    b = rf.RiverNetworkBuilder()
    t = np.linspace(0.0, 4.0 * np.pi, 400)
    xy = np.c_[10.0 * t, 12.0 * np.sin(t)]    # a creek bending every ~30 m (radius 8 m)
    b.add_branch(xy, widths_m=2.0, discharge_m2s=1.0, name="creek")
    graph = b.build()
    width = max(c.width_m for c in graph.curves)          # the axis's, as the graph holds it
    land = rf.landscape(graph, seed=0)
    (branch,) = land.branches
    steps = np.linalg.norm(np.diff(branch.centerline_m, axis=0), axis=1)
    assert steps.max() <= width + 1e-6
    # its bends are kept: the resampled line stays well inside the creek
    off = shapely.distance(shapely.LineString(xy), shapely.points(branch.centerline_m))
    assert off.max() < 0.1 * width, off.max()


def test_the_land_level_lattice_is_one_function_of_the_point():
    """carving.lattice_land_level reads a compact batch (a tile's nodes) from the lattice's
    whole box around it and a spread one through its unique nodes: the same value at the same
    point either way, and the water's own land level at lattice nodes."""
    from riverflow.scenes.carving import lattice_land_level

    scene = rf.default_scene(seed=0)
    water = scene.water
    anchor = (scene.quadtree.root_x_m, scene.quadtree.root_y_m)
    centre = scene.branch("tributary").centerline_m[40]
    k = np.arange(-33, 34) * 4.0
    gx, gy = np.meshgrid(centre[0] + k, centre[1] + k)
    tile = np.column_stack([gx.ravel(), gy.ravel()])                 # a tile of 4 m cells
    spread = np.vstack([tile[::37], centre + [[1500.0, -900.0]]])    # sparse, far apart
    compact = lattice_land_level(water, tile, 16.0, anchor)[::37]
    sparse = lattice_land_level(water, spread, 16.0, anchor)
    assert np.array_equal(compact, sparse[:-1])
    nodes = np.asarray(anchor) + 16.0 * np.round((tile[::97] - anchor) / 16.0)
    assert np.allclose(lattice_land_level(water, nodes, 16.0, anchor), water.land_level(nodes),
                       rtol=0, atol=1e-9)


def _old_land_and_bank_levels(water, p, shore):
    """WaterSurface.land_level and bank_level as they were: a KD-tree's k nearest samples,
    mixed in numpy (the numpy reference of riverflow.kernels.level_mix)."""
    from riverflow.scenes import water as w

    out = []
    for stride, k, band in ((w.LAND_LEVEL_STRIDE, w.LAND_LEVEL_NEIGHBOURS, np.inf),
                            (1, w.BANK_LEVEL_NEIGHBOURS,
                             w.BANK_BLEND * np.maximum(shore, 0.0)[:, None] + w.BANK_BLEND_MIN_M)):
        samples = water.decimated(stride)
        d, idx = samples.tree.query(p, k=k)
        extra = d - d[:, :1]
        span = np.maximum(extra[:, -1:], 1e-9)
        wt = (1.0 - extra / span) ** 2 * np.clip(1.0 - extra / band, 0.0, 1.0) ** 2
        wt[:, 0] = np.maximum(wt[:, 0], 1e-12)
        out.append((wt * samples.levels[idx]).sum(axis=1) / wt.sum(axis=1))
    return out


def _old_lattice_land_level(water, xy, lattice_m, anchor_m):
    """carving.lattice_land_level as it was: every needed corner's land level, by masks."""
    g = (xy - np.asarray(anchor_m, np.float64)) / lattice_m
    ij = np.floor(g).astype(np.int64)
    f = g - ij
    on_x, on_y = f[:, 0] == 0.0, f[:, 1] == 0.0
    need = np.concatenate([np.ones(len(ij), bool), ~on_x, ~on_y, ~(on_x | on_y)])
    corners = np.concatenate([ij, ij + [1, 0], ij + [0, 1], ij + [1, 1]])[need]
    values = np.zeros(len(need))
    values[need] = water.land_level(np.asarray(anchor_m) + corners * lattice_m)
    v = values.reshape(4, -1)
    fx, fy = np.where(on_x, 0.0, f[:, 0]), np.where(on_y, 0.0, f[:, 1])
    return (1 - fy) * ((1 - fx) * v[0] + fx * v[1]) + fy * ((1 - fx) * v[2] + fx * v[3])


def test_the_land_levels_and_the_nearest_centre_line_point_are_the_kd_tree_formulas():
    """WaterSurface.land_level, bank_level and nearest (box-hierarchy kernels) give the
    numbers of the KD-tree and numpy formulas they replace, within rounding, at points near
    and far from the rivers, on samples (junctions' shared points: ties) and at a tile's
    nodes, in one batch or in shuffled chunks; lattice_land_level gives its masked
    version's."""
    from riverflow.kernels.centre_line import project_to_centre
    from riverflow.scenes.carving import lattice_land_level

    scene = rf.default_scene(seed=0)
    water = scene.water
    rng = np.random.default_rng(11)
    s = water.samples_m
    centre = scene.branch("tributary").centerline_m[40]
    gx, gy = np.meshgrid(centre[0] + np.arange(-33, 34) * 4.0, centre[1] + np.arange(-33, 34) * 4.0)
    p = np.vstack([s[rng.integers(0, len(s), 1500)] + rng.normal(size=(1500, 2)) * 20.0,
                   s[rng.integers(0, len(s), 1500)] + rng.normal(size=(1500, 2)) * 500.0,
                   s[rng.integers(0, len(s), 200)], water.junctions_m,
                   np.column_stack([gx.ravel(), gy.ravel()])[::3]])
    shore = rng.uniform(0.0, 30.0, len(p))
    want_land, want_bank = _old_land_and_bank_levels(water, p, shore)
    samples = water.decimated(1)
    _, k = samples.tree.query(p)
    want_near = np.empty((3, len(p)))
    project_to_centre(samples.kernel_samples, k, p, *want_near)
    order = rng.permutation(len(p))
    for piece in [np.arange(len(p))] + np.split(order, [7, 500, 2100]):
        np.testing.assert_allclose(water.land_level(p[piece]), want_land[piece], rtol=1e-12)
        np.testing.assert_allclose(water.bank_level(p[piece], shore[piece]), want_bank[piece],
                                   rtol=1e-12)
        assert np.array_equal(np.array(samples.project(p[piece])), want_near[:, piece])
    anchor = (scene.quadtree.root_x_m, scene.quadtree.root_y_m)
    tile = np.column_stack([gx.ravel(), gy.ravel()])
    for batch in (tile, tile[::5], p, np.round(p / 8.0) * 8.0):
        np.testing.assert_allclose(lattice_land_level(water, batch, 16.0, anchor),
                                   _old_lattice_land_level(water, batch, 16.0, anchor), rtol=1e-12)


def test_height_and_water_tiles_share_their_shore_query_and_match_the_pointwise_terrain():
    """tile_kinds.LandscapeTiles.shore: one shore-distance query for a tile's height and water
    producers (whichever comes first); their tiles are the pointwise terrain's and water's."""
    from riverflow.scenes.tile_kinds import LEVEL_REACH_M, terrain_producers

    scene = rf.default_scene(seed=0)
    height, water = terrain_producers(scene)[:2]
    tiles = height.tiles
    centre = scene.branch("tributary").centerline_m[40]
    level = tiles.max_level
    key = (level, *tiles.quadtree.tile_of(*centre, level))
    n = tiles.n
    for first, second in ((height, water), (water, height)):
        got = {p.kind: p.produce(key, {}) for p in (first, second)}
        assert not tiles._shores                       # handed on, not kept
        nodes = tiles.nodes(key, n, ring=1)
        assert np.array_equal(got["height"]["z"].ravel(),
                              scene.terrain.height(nodes).astype(np.float32))
        inner = tiles.nodes(key, n)
        d = scene.water.distance_to_shore(inner, upper_bound_m=LEVEL_REACH_M)
        inside = scene.water.contains(inner, d)
        signed = np.where(np.isfinite(d), np.where(inside, -d, d), LEVEL_REACH_M)
        assert np.array_equal(got["water"]["shore"].ravel(), signed.astype(np.float32))
        assert (signed < 0).any() and (signed > 20).any()  # the tile holds water and land


def test_a_tiles_shore_record_makes_each_nodes_centre_line_query_once():
    """TileShore.centre: the level and width of WaterSurface.nearest at the nodes asked for,
    each node queried once whichever producer asks first (carve's nodes, then the water
    tile's, which include most of them)."""
    from riverflow.scenes.tile_kinds import TileShore

    scene = rf.default_scene(seed=0)
    water = scene.water
    centre = scene.branch("tributary").centerline_m[40]
    k = np.arange(-12, 13) * 6.0
    gx, gy = np.meshgrid(centre[0] + k, centre[1] + k)
    nodes = np.column_stack([gx.ravel(), gy.ravel()])
    shore = water.distance_to_shore(nodes, upper_bound_m=200.0)
    asked = []
    real = water.nearest

    class Counting:
        def __getattr__(self, name):
            return getattr(water, name)

        def nearest(self, xy):
            asked.append(len(xy))
            return real(xy)

    record = TileShore(nodes, shore, water.contains(nodes, shore), Counting())
    first, second = np.arange(0, 400), np.arange(200, len(nodes))
    for idx in (first, second, first):
        level, width = record.centre(idx)
        _, want_level, want_width = real(nodes[idx])
        assert np.array_equal(level, want_level) and np.array_equal(width, want_width)
    assert asked == [400, len(nodes) - 400]


def test_the_source_under_height_tiles_is_kept_across_edits_and_dropped_with_its_source():
    """SourceTiles: a height tile's source heights are made once and read back (bit for bit
    the source's), an edited network's terrain takes them over (the source is the same),
    keep_sources makes only the missing ones, and a terrain on another source or another
    tile grid starts empty."""
    from riverflow.engine.edits import edited_scene
    from riverflow.scenes.landscape import CarvedTerrain
    from riverflow.scenes.sources import FbmSource
    from riverflow.scenes.tile_kinds import keep_sources, terrain_producers
    from riverflow.tiles.table import tile_code

    scene = rf.default_scene(seed=0)
    height = terrain_producers(scene)[0]
    kept = scene.terrain.source_tiles
    centre = scene.branch("tributary").centerline_m[40]
    level = height.tiles.max_level
    key = (level, *scene.quadtree.tile_of(*centre, level))
    first = height.produce(key, {})
    assert key in kept
    nodes = height.tiles.nodes(key, height.tiles.n, ring=1)
    z = kept.heights(key, nodes)
    assert np.array_equal(z, scene.terrain.source.heights(nodes[:, 0], nodes[:, 1]))
    assert kept.heights(key, nodes) is z                       # read back, not made again
    new, _ = edited_scene(scene, scene.branches)
    assert new.terrain.source_tiles is kept
    again = terrain_producers(new)[0].produce(key, {})
    assert np.array_equal(again["z"], first["z"])             # (the same network)
    spare = next((level, key[1] + k, key[2]) for k in range(1, 64)   # (the scene may be
                 if (level, key[1] + k, key[2]) not in kept)      # shared in the run)
    codes = np.array([tile_code(*key), tile_code(*spare)], np.int64)
    waits = []                                 # (an edit's thread waits for the frame)
    assert keep_sources(new, codes, lambda: waits.append(1)) == 1 and waits == [1]
    assert keep_sources(new, codes, lambda: waits.append(1)) == 0 and waits == [1]
    t = scene.terrain
    other = CarvedTerrain(FbmSource(7), t.water, t.carving, t.quadtree, t.cell_m, t.tile_cells,
                          kept)
    assert other.source_tiles is not kept and len(other.source_tiles) == 0
    coarser = CarvedTerrain(t.source, t.water, t.carving, t.quadtree, t.cell_m, 32, kept)
    assert coarser.source_tiles is not kept
    same = CarvedTerrain(t.source, t.water, t.carving, t.quadtree, t.cell_m, t.tile_cells, kept)
    assert same.source_tiles is kept


def test_the_water_surface_is_sampled_segment_by_segment():
    """resample_segments keeps every vertex, samples each segment at most the spacing apart
    (values linear along it), so moving one vertex changes only its two segments' samples."""
    from riverflow.scenes.water import resample_segments

    rng = np.random.default_rng(3)
    line = np.cumsum(rng.uniform(3.0, 9.0, (12, 2)), axis=0)
    value = np.arange(12, dtype=np.float64)
    pts, v, vertex = resample_segments(line, 2.0, value)
    assert np.array_equal(pts[vertex], line) and np.array_equal(v[vertex], value)
    assert np.hypot(*np.diff(pts, axis=0).T).max() <= 2.0 + 1e-12
    np.testing.assert_allclose(np.interp(np.arange(len(v)), np.flatnonzero(vertex), value), v)
    moved = line.copy()
    moved[6] += (3.0, -2.0)
    pts2, _, vertex2 = resample_segments(moved, 2.0, value)
    first = np.flatnonzero(vertex)[5]                     # vertex 5: its samples before kept
    last = len(pts) - np.flatnonzero(vertex)[7]            # from vertex 7 on: kept
    assert np.array_equal(pts[:first + 1], pts2[:first + 1])
    assert np.array_equal(pts[-last:], pts2[-last:])


def test_channels_parting_where_no_branch_flows_in_get_one_finite_level():
    """Two channels leaving a junction no branch ends at (a river split round an island at
    the data's edge, as Porto's Douro comes in): the junction's level was never set (inf),
    and inf × 0 made every level NaN (the world drew nothing but fog)."""
    from riverflow.scenes.water import monotone_profiles

    up = np.c_[np.linspace(0.0, 500.0, 26), np.zeros(26)]
    arm = [up + (0.0, 40.0), up - (0.0, 40.0)]
    below = np.c_[np.linspace(500.0, 900.0, 21), np.zeros(21)]
    ground = [12.0 - 0.01 * a[:, 0] for a in arm] + [12.0 - 0.01 * below[:, 0]]
    ground[1] = ground[1] - 0.5                      # the second arm's ground lower
    with np.errstate(all="raise"):
        levels = monotone_profiles([*arm, below], ground, [0, 0, 1], [1, 1, -1], 2,
                                   half_window=3, caps_m=[(30.0, 30.0)] * 3)
    assert all(np.isfinite(z).all() for z in levels)
    assert levels[0][0] == levels[1][0]                  # one level where they part
    assert levels[0][-1] == levels[1][-1] == levels[2][0]
    assert all((np.diff(z) <= 0).all() for z in levels)
