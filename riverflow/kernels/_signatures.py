"""Argument types of riverflow's kernels per group, for the warm-up
(:mod:`riverflow.kernels.warmup`).

Written by ``tools/record_kernel_signatures.py`` (numba 0.68.1, Python 3.11.7): do
not edit; run ``make kernel-signatures`` after changing a kernel's arguments.
"""

SIGNATURES = {
    'field': {
        'polyline.nearest_points': [
            "(Named(riverflow.kernels.polyline.Polyline, (A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 2, 'C'), float64, Named(riverflow.kernels.polyline.Nearest, (A(int64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), )))",
        ],
        'noise.fbm': [
            "(A(float64, 1, 'C'), A(float64, 1, 'C'), uint64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'))",
        ],
        'tile_table.table_insert_many': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'))",
        ],
        'flow.query_velocity': [
            "(A(float64, 2, 'C'), A(int8, 1, 'C'), int64, int64, Named(riverflow.kernels.flow.CachedTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(float32, 3, 'C'), A(uint8, 3, 'C'), A(int32, 4, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), )), int64, Named(riverflow.kernels.flow.Segments, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), int64, A(uint8, 1, 'C'), A(float32, 2, 'C'))",
        ],
        'tile_table.mark_used': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), int64, A(int64, 1, 'C'), int64, A(int64, 1, 'C'))",
        ],
        'tile_table.table_find': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), int64)",
        ],
        'flow.build_flow_tile': [
            "(float64, float64, float64, int64, int64, int64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), float64, A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(bool, 2, 'C'), A(float64, 3, 'C'), A(float32, 2, 'C'), A(uint8, 2, 'C'), A(int32, 3, 'C'), A(float32, 2, 'C'))",
        ],
        'tile_table.table_insert': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), int64, int32)",
        ],
        'flow.sample_potential': [
            "(A(float64, 2, 'C'), A(int8, 1, 'C'), int64, int64, Named(riverflow.kernels.flow.CachedTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(float32, 3, 'C'), A(uint8, 3, 'C'), A(int32, 4, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), )), int64, Named(riverflow.kernels.flow.Segments, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 1, 'C'))",
        ],
    },
    'scene': {
        'polyline.nearest_points': [
            "(Named(riverflow.kernels.polyline.Polyline, (A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 2, 'C'), float64, Named(riverflow.kernels.polyline.Nearest, (A(int64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), )))",
        ],
        'noise.fbm': [
            "(A(float64, 1, 'C'), A(float64, 1, 'C'), uint64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'))",
        ],
    },
    'world': {
        'polyline.nearest_points': [
            "(Named(riverflow.kernels.polyline.Polyline, (A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 2, 'C'), float64, Named(riverflow.kernels.polyline.Nearest, (A(int64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), )))",
        ],
        'noise.fbm': [
            "(A(float64, 1, 'C'), A(float64, 1, 'C'), uint64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'))",
        ],
        'tile_table.table_insert_many': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'))",
        ],
        'flow.query_velocity': [
            "(A(float64, 2, 'C'), A(int8, 1, 'C'), int64, int64, Named(riverflow.kernels.flow.CachedTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(float32, 3, 'C'), A(uint8, 3, 'C'), A(int32, 4, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), )), int64, Named(riverflow.kernels.flow.Segments, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), int64, A(uint8, 1, 'C'), A(float32, 2, 'C'))",
        ],
        'tile_table.mark_used': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), int64, A(int64, 1, 'C'), int64, A(int64, 1, 'C'))",
        ],
        'tile_table.table_find': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), int64)",
        ],
        'flow.build_flow_tile': [
            "(float64, float64, float64, int64, int64, int64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), float64, A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(bool, 2, 'C'), A(float64, 3, 'C'), A(float32, 2, 'C'), A(uint8, 2, 'C'), A(int32, 3, 'C'), A(float32, 2, 'C'))",
        ],
        'tile_table.table_insert': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), int64, int32)",
        ],
        'flow.sample_potential': [
            "(A(float64, 2, 'C'), A(int8, 1, 'C'), int64, int64, Named(riverflow.kernels.flow.CachedTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(float32, 3, 'C'), A(uint8, 3, 'C'), A(int32, 4, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), )), int64, Named(riverflow.kernels.flow.Segments, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 1, 'C'))",
        ],
        'raycast.pyramid_size': [
            '(int64, int64)',
        ],
        'view_tiles.select_view_tiles': [
            "(A(float64, 2, 'C'), float64, float64, float64, float64, float64, float64, float64, float64, int64, int64, float64, float64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int32, 2, 'C'))",
        ],
        'tile_table.codes_of': [
            "(A(int64, 2, 'C'), A(int64, 1, 'C'))",
        ],
        'tile_table.table_find_many': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'))",
        ],
        'raycast.fill_height_pyramid': [
            "(A(float32, 2, 'C'), A(float32, 2, 'C'), A(float32, 2, 'C'))",
        ],
        'tile_table.table_rehash': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'))",
        ],
        'surface_tiles.leaf_standins': [
            "(A(int32, 2, 'C'), int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 2, 'C'))",
        ],
        'advection.move_particles': [
            "(int64, A(bool, 1, 'C'), A(bool, 1, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), float64, Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), int64, int64, int64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(float64, 2, 'C'))",
        ],
        'advection.apply_flow_status': [
            "(A(bool, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), int64, A(int32, 1, 'C'), A(uint8, 1, 'C'), A(float32, 2, 'C'), int64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), float64)",
        ],
        'advection.check_outside_near_water': [
            "(A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), A(float32, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), float64, float64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), float64, A(uint8, 1, 'C'), int64, int64, int64, float64, int64, int64, A(float64, 2, 'C'), float64, float64, Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), A(float32, 2, 'C'), A(int32, 1, 'C'))",
        ],
        'screen.project_particles': [
            "(A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'), A(float64, 1, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), int64, int64, float64, float64, float64, float64, float64)",
        ],
        'lifecycle.age_particles': [
            "(A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), float64, float64, float64, float64)",
        ],
        'poisson_fill.blocked_direction_table': [
            "(float64, float64, float64, A(uint64, 2, 'C'), A(uint64, 2, 'C'))",
        ],
        'poisson_cull.cull_crowded_particles': [
            "(A(bool, 1, 'C'), A(float32, 2, 'C'), A(float64, 1, 'C'), A(uint8, 1, 'C'), A(uint8, 1, 'C'), float64, float64, float64, float64, float64, float64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(uint8, 1, 'C'), A(uint8, 1, 'C'), int64, int64, int64)",
        ],
        'poisson_fill.fill_poisson_holes': [
            "(A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), float64, float64, float64, float64, float64, int64, int64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), int64, float64, float64, float64, float64, A(int32, 1, 'C'), A(int32, 1, 'C'), A(uint64, 2, 'C'), A(uint64, 2, 'C'), float64)",
        ],
        'placement.pixel_rays': [
            "(A(int32, 1, 'C'), int64, A(float32, 2, 'C'), A(float64, 2, 'C'), int64, int64, A(float64, 2, 'C'), A(float64, 2, 'C'))",
        ],
        'raycast_tiles.cast_rays_onto_tiles': [
            "(A(float64, 2, 'C'), A(float64, 2, 'C'), Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), float64, A(float64, 2, 'C'), A(uint8, 1, 'C'))",
        ],
        'placement.place_particles': [
            "(A(int32, 1, 'C'), int64, A(float64, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(bool, 1, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'))",
        ],
        'placement.drop_unseen': [
            "(A(int32, 1, 'C'), int64, A(uint8, 1, 'C'), int64, A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'))",
        ],
        'placement.select_new_on_ground': [
            "(A(int32, 1, 'C'), int64, A(bool, 1, 'C'), A(float64, 2, 'C'), A(int32, 1, 'C'), A(float64, 2, 'C'))",
        ],
        'foam.update_foam': [
            "(int64, A(bool, 1, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(int64, 1, 'C'), Named(riverflow.kernels.foam.FoamParams, (float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, )), Named(riverflow.kernels.foam.FoamFlow, (Named(riverflow.kernels.flow.CachedTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(float32, 3, 'C'), A(uint8, 3, 'C'), A(int32, 4, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), )), A(float32, 3, 'C'), int64, int64, Named(riverflow.kernels.falls.FallTable, (A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), )), Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), Named(riverflow.kernels.foam.FoamSources, (A(float64, 2, 'C'), A(float32, 3, 'C'), )), Named(riverflow.kernels.foam.ScreenNeighbours, (float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), float64, )), float64, int64, int64, int64, A(int32, 1, 'C'))",
        ],
        'advection.place_at_seen_water': [
            "(A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), float64, float64, float64, float64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), int64, A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(uint8, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), int64, float64, float64, float64, float64, A(int32, 1, 'C'))",
        ],
        'rain.drops_this_frame': [
            '(float64, float64, float64, float64, float64)',
        ],
        'rain.step_rain': [
            "(Named(riverflow.kernels.rain.RainDrops, (A(float64, 2, 'C'), A(float64, 2, 'C'), A(int64, 1, 'C'), A(float64, 2, 'C'), )), int64, A(float64, 2, 'C'), float64, float64, float64, float64, float64, float64, A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), float64, Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), bool, float64)",
        ],
        'tile_table.table_remove': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), int64)",
        ],
        'surface_tiles.water_level_at': [
            "(Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), float64, float64)",
        ],
        'wake.advance_trail': [
            "(A(float64, 2, 'C'), int64, float64, float64, float64, float64, float64, float64, float64, float64, float64)",
        ],
        'wake.pack_trail': [
            "(A(float64, 2, 'C'), int64, float64, float64, float64, float64, float64, float64, A(float32, 2, 'C'))",
        ],
        'obstacles.select_obstacle_points': [
            "(A(float64, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(int64, 1, 'C'))",
        ],
        'obstacles.apply_obstacles': [
            "(A(float64, 2, 'C'), A(int64, 1, 'C'), int64, A(float64, 1, 'C'), A(float64, 2, 'C'), A(uint8, 1, 'C'), A(float32, 2, 'C'))",
        ],
    },
    'draw': {
        'waves.ripple_heights': [
            "(int64, A(float64, 2, 'C'))",
        ],
        'waves.slopes_from_heights': [
            "(A(float64, 3, 'C'), float64)",
        ],
        'waves.downsample_2x2': [
            "(A(float64, 4, 'C'),)",
        ],
        'waves.permutation': [
            '(int64,)',
        ],
        'waves.gradients_2d': [
            '()',
        ],
        'waves.perlin_tile_2d': [
            "(int64, int64, int64, A(int64, 1, 'C'), A(float64, 2, 'C'))",
        ],
        'waves.gradients_3d': [
            '()',
        ],
        'waves.perlin_frames_3d': [
            "(int64, A(float64, 1, 'C'), int64, int64, int64, A(int64, 1, 'C'), A(float64, 2, 'C'))",
        ],
        '_jit.is_finite': [
            '(float64,)',
        ],
        'sprites.slot_span': [
            "(A(bool, 1, 'C'),)",
        ],
        'sprites.build_sprite_tables': [
            "(Named(riverflow.kernels.sprites.SpriteSource, (A(bool, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(uint8, 1, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(float32, 2, 'C'), )), float64, int64, Named(riverflow.kernels.sprites.SpriteBins, (int64, int64, int64, int64, int64, int64, )), A(float32, 3, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), bool)",
        ],
        'tile_cut.cut_standins': [
            "(A(int32, 2, 'C'), int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(bool, 1, 'C'), A(int32, 2, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'))",
        ],
        'tile_cut.coarser_across': [
            "(A(int64, 2, 'C'), A(int64, 2, 'C'))",
        ],
        'tile_cut.edge_parts': [
            "(A(int64, 2, 'C'), A(int64, 2, 'C'), A(int32, 1, 'C'), Named(riverflow.kernels.tile_cut.EdgeParts, (A(int32, 3, 'C'), A(int64, 3, 'C'), A(int32, 3, 'C'), A(int64, 3, 'C'), )))",
        ],
        'tile_cut.near_to_far': [
            "(A(int32, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C', readonly=True), A(int32, 1, 'C'))",
        ],
        'centre_line.nearest_level': [
            "(A(float64, 2, 'C'), A(float64, 1, 'C'), A(int64, 1, 'C'), float64, float64)",
        ],
        'centre_line.view_level': [
            "(Named(riverflow.kernels.centre_line.LevelSamples, (A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 2, 'C'), A(float64, 1, 'C'), float64, float64, float64, float64)",
        ],
    },
}

# seconds to compile each kernel on a cold cache when recorded (the warm-up starts
# the costliest first, so that side-by-side compiling ends together)
COSTS = {
    'foam.update_foam': 121.97,
    'raycast_tiles.cast_rays_onto_tiles': 54.28,
    'poisson_fill.fill_poisson_holes': 41.27,
    'flow.build_flow_tile': 30.38,
    'poisson_cull.cull_crowded_particles': 18.65,
    'tile_cut.coarser_across': 17.62,
    'rain.step_rain': 17.04,
    'flow.query_velocity': 16.50,
    'flow.sample_potential': 14.65,
    'sprites.build_sprite_tables': 12.61,
    'tile_cut.cut_standins': 11.32,
    'advection.check_outside_near_water': 10.84,
    'tile_cut.near_to_far': 10.36,
    'advection.move_particles': 8.77,
    'advection.place_at_seen_water': 6.38,
    'view_tiles.select_view_tiles': 5.18,
    'polyline.nearest_points': 5.09,
    'surface_tiles.water_level_at': 4.56,
    'noise.fbm': 4.29,
    'waves.perlin_frames_3d': 3.61,
    'centre_line.view_level': 3.35,
    'waves.perlin_tile_2d': 3.35,
    'obstacles.apply_obstacles': 3.26,
    'raycast.fill_height_pyramid': 3.13,
    'centre_line.nearest_level': 2.93,
    'placement.pixel_rays': 2.87,
    'wake.advance_trail': 2.72,
    'screen.project_particles': 2.65,
    'advection.apply_flow_status': 2.47,
    'tile_cut.edge_parts': 2.42,
    'waves.ripple_heights': 2.41,
    'waves.downsample_2x2': 1.79,
    'waves.permutation': 1.71,
    'wake.pack_trail': 1.64,
    'poisson_fill.blocked_direction_table': 1.60,
    'waves.slopes_from_heights': 1.57,
    'surface_tiles.leaf_standins': 1.35,
    'placement.drop_unseen': 1.22,
    'tile_table.table_find_many': 1.20,
    'tile_table.table_insert_many': 1.18,
    'placement.place_particles': 1.14,
    'tile_table.table_remove': 1.12,
    'obstacles.select_obstacle_points': 1.09,
    'tile_table.mark_used': 0.96,
    'tile_table.table_rehash': 0.92,
    'raycast.pyramid_size': 0.88,
    'placement.select_new_on_ground': 0.80,
    'rain.drops_this_frame': 0.65,
    'waves.gradients_3d': 0.64,
    'tile_table.table_find': 0.61,
    'tile_table.codes_of': 0.61,
    'lifecycle.age_particles': 0.56,
    'waves.gradients_2d': 0.55,
    'sprites.slot_span': 0.19,
    '_jit.is_finite': 0.12,
    'tile_table.table_insert': 0.01,
}
