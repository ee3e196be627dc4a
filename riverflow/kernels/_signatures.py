"""Argument types of riverflow's kernels per group, for the warm-up
(:mod:`riverflow.kernels.warmup`).

Written by ``tools/record_kernel_signatures.py`` (numba 0.68.1, Python 3.11.7): do
not edit; run ``make kernel-signatures`` after changing a kernel's arguments.
"""

SIGNATURES = {
    'field': {
        'fillets.outline': [
            "(A(float64, 2, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'))",
        ],
        'fillets.corner_fillets': [
            "(Named(riverflow.kernels.fillets.Outline, (A(float64, 2, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), )), float64, float64, float64, float64, float64, float64, A(float64, 1, 'C'), float64)",
        ],
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
            "(float64, float64, float64, int64, int64, int64, Named(riverflow.kernels.flow.Network, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), )), float64, Named(riverflow.kernels.flow.BoxLists, (A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), Named(riverflow.kernels.flow.TileScratch, (A(float64, 1, 'C'), A(float64, 2, 'C'), A(bool, 2, 'C'), A(float64, 3, 'C'), )), Named(riverflow.kernels.flow.TileOut, (A(float32, 2, 'C'), A(uint8, 2, 'C'), A(int32, 3, 'C'), A(float32, 2, 'C'), A(float32, 2, 'C'), )))",
        ],
        'tile_table.table_insert': [
            "(A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), int64, int32)",
        ],
        'flow.sample_potential': [
            "(A(float64, 2, 'C'), A(int8, 1, 'C'), int64, int64, Named(riverflow.kernels.flow.CachedTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(float32, 3, 'C'), A(uint8, 3, 'C'), A(int32, 4, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), )), int64, Named(riverflow.kernels.flow.Segments, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 1, 'C'))",
        ],
    },
    'scene': {
        'fillets.outline': [
            "(A(float64, 2, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'))",
        ],
        'fillets.corner_fillets': [
            "(Named(riverflow.kernels.fillets.Outline, (A(float64, 2, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), )), float64, float64, float64, float64, float64, float64, A(float64, 1, 'C'), float64)",
        ],
        'polyline.nearest_points': [
            "(Named(riverflow.kernels.polyline.Polyline, (A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 2, 'C'), float64, Named(riverflow.kernels.polyline.Nearest, (A(int64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), )))",
        ],
        'noise.fbm': [
            "(A(float64, 1, 'C'), A(float64, 1, 'C'), uint64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'))",
        ],
    },
    'world': {
        'fillets.outline': [
            "(A(float64, 2, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'))",
        ],
        'fillets.corner_fillets': [
            "(Named(riverflow.kernels.fillets.Outline, (A(float64, 2, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), )), float64, float64, float64, float64, float64, float64, A(float64, 1, 'C'), float64)",
        ],
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
            "(float64, float64, float64, int64, int64, int64, Named(riverflow.kernels.flow.Network, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), )), float64, Named(riverflow.kernels.flow.BoxLists, (A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), Named(riverflow.kernels.flow.TileScratch, (A(float64, 1, 'C'), A(float64, 2, 'C'), A(bool, 2, 'C'), A(float64, 3, 'C'), )), Named(riverflow.kernels.flow.TileOut, (A(float32, 2, 'C'), A(uint8, 2, 'C'), A(int32, 3, 'C'), A(float32, 2, 'C'), A(float32, 2, 'C'), )))",
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
        'level_mix.nearest_samples': [
            "(Named(riverflow.kernels.level_mix.MixSamples, (A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(int64, 1, 'C'), )), A(float64, 2, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'))",
        ],
        'centre_line.project_to_centre': [
            "(Named(riverflow.kernels.centre_line.CentreSamples, (A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int64, 1, 'C'), )), A(int64, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'))",
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
        'level_mix.mixed_levels': [
            "(Named(riverflow.kernels.level_mix.MixSamples, (A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(int64, 1, 'C'), )), int64, A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'))",
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
            "(Named(riverflow.kernels.lifecycle.Pool, (A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), )), Named(riverflow.kernels.poisson_cull.Grid, (int64, int64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(uint8, 1, 'C'), A(uint8, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), )), float64, float64, float64, int64, int64, int64, float64, int64, int64, A(float64, 2, 'C'), float64, float64, Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), A(float32, 2, 'C'), A(int32, 1, 'C'))",
        ],
        'screen.project_particles': [
            "(A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'), A(float64, 1, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), int64, int64, float64, float64, float64, float64, float64)",
        ],
        'lifecycle.age_particles': [
            "(A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), float64, float64, float64, float64)",
        ],
        'poisson_cull.cull_crowded_particles': [
            "(Named(riverflow.kernels.lifecycle.Pool, (A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), )), Named(riverflow.kernels.poisson_cull.Grid, (int64, int64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(uint8, 1, 'C'), A(uint8, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), )), float64, float64, float64, float64, float64, float64, int64, int64)",
        ],
        'poisson_fill.blocked_direction_table': [
            "(float64, float64, float64, A(uint64, 2, 'C'), A(uint64, 2, 'C'))",
        ],
        'poisson_fill.fill_poisson_holes': [
            "(Named(riverflow.kernels.lifecycle.Pool, (A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), )), Named(riverflow.kernels.poisson_cull.Grid, (int64, int64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(uint8, 1, 'C'), A(uint8, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), )), Named(riverflow.kernels.poisson_fill.DirectionTable, (A(uint64, 2, 'C'), A(uint64, 2, 'C'), float64, )), float64, float64, float64, int64, float64, float64, float64, float64)",
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
            "(int64, Named(riverflow.kernels.lifecycle.Pool, (A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), )), Named(riverflow.kernels.foam.FoamParams, (float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, )), Named(riverflow.kernels.foam.FoamFlow, (Named(riverflow.kernels.flow.CachedTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(float32, 3, 'C'), A(uint8, 3, 'C'), A(int32, 4, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), )), A(float32, 3, 'C'), A(float32, 3, 'C'), int64, int64, Named(riverflow.kernels.falls.FallTable, (A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), )), Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), Named(riverflow.kernels.foam.FoamSources, (A(float64, 2, 'C'), A(float32, 3, 'C'), )), Named(riverflow.kernels.foam.ScreenNeighbours, (float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), float64, )), float64, int64, int64, int64, A(int32, 1, 'C'))",
        ],
        'advection.place_at_seen_water': [
            "(Named(riverflow.kernels.lifecycle.Pool, (A(bool, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(bool, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(int64, 1, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), )), Named(riverflow.kernels.poisson_cull.Grid, (int64, int64, float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(uint8, 1, 'C'), A(uint8, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), )), Named(riverflow.kernels.advection.Probes, (A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float64, 2, 'C'), A(uint8, 1, 'C'), A(float32, 2, 'C'), )), int64, float64, float64, float64, float64, int64, float64, float64, float64, float64)",
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
        'spill.spill_steps': [
            "(Named(riverflow.kernels.spill.SpillNet, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), )), Named(riverflow.kernels.spill.SpillBook, (A(float64, 2, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), )), float64, float64, int64, A(float64, 1, 'C'), A(float64, 1, 'C'))",
        ],
        'flood.flood_steps': [
            "(Named(riverflow.kernels.flood.FloodNet, (A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), )), Named(riverflow.kernels.flood.Hydrographs, (A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), A(float64, 1, 'C'), float64, float64, int64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'))",
        ],
        'flood.sample_by_cells': [
            "(A(float64, 2, 'C'), int64, Named(riverflow.kernels.flood.CellRaster, (float64, float64, float64, int64, A(int32, 2, 'C'), A(float64, 3, 'C'), )), A(float64, 1, 'C'), float64, A(float64, 1, 'C'))",
        ],
        'flood.scale_by_cells': [
            "(A(float64, 2, 'C'), A(float32, 2, 'C'), int64, Named(riverflow.kernels.flood.CellRaster, (float64, float64, float64, int64, A(int32, 2, 'C'), A(float64, 3, 'C'), )), A(float64, 1, 'C'), A(int64, 1, 'C'))",
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
        'spill.sample_tint': [
            "(Named(riverflow.kernels.spill.TintGrid, (A(float32, 3, 'C'), A(float64, 1, 'C'), )), Named(riverflow.kernels.spill.ParticleTint, (A(bool, 1, 'C'), A(bool, 1, 'C'), A(int64, 1, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'), A(int64, 1, 'C'), )), int64, int64, int64, bool)",
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
        'spill.tint_texels': [
            "(Named(riverflow.kernels.spill.TintTexels, (A(int64, 1, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(int64, 1, 'C'), A(int64, 1, 'C'), )), A(float64, 2, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'))",
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
    'foam.update_foam': 51.48,
    'flow.build_flow_tile': 21.82,
    'raycast_tiles.cast_rays_onto_tiles': 18.95,
    'fillets.corner_fillets': 18.46,
    'poisson_fill.fill_poisson_holes': 12.85,
    'poisson_cull.cull_crowded_particles': 11.15,
    'flow.query_velocity': 8.31,
    'advection.check_outside_near_water': 6.25,
    'tile_cut.coarser_across': 6.21,
    'rain.step_rain': 5.27,
    'flow.sample_potential': 5.07,
    'tile_cut.cut_standins': 4.12,
    'sprites.build_sprite_tables': 3.74,
    'advection.move_particles': 3.51,
    'level_mix.mixed_levels': 3.28,
    'tile_cut.near_to_far': 3.00,
    'noise.fbm': 2.18,
    'advection.place_at_seen_water': 2.18,
    'level_mix.nearest_samples': 1.86,
    'waves.perlin_frames_3d': 1.72,
    'polyline.nearest_points': 1.57,
    'view_tiles.select_view_tiles': 1.53,
    'spill.spill_steps': 1.52,
    'spill.sample_tint': 1.49,
    'surface_tiles.water_level_at': 1.39,
    'raycast.fill_height_pyramid': 1.33,
    'fillets.outline': 1.32,
    'waves.perlin_tile_2d': 1.27,
    'flood.flood_steps': 1.26,
    'screen.project_particles': 1.17,
    'centre_line.nearest_level': 1.03,
    'obstacles.apply_obstacles': 1.02,
    'centre_line.view_level': 0.97,
    'centre_line.project_to_centre': 0.96,
    'advection.apply_flow_status': 0.94,
    'waves.permutation': 0.90,
    'placement.pixel_rays': 0.85,
    'poisson_fill.blocked_direction_table': 0.76,
    'spill.tint_texels': 0.75,
    'wake.advance_trail': 0.72,
    'waves.ripple_heights': 0.72,
    'wake.pack_trail': 0.71,
    'tile_cut.edge_parts': 0.70,
    'flood.scale_by_cells': 0.65,
    'flood.sample_by_cells': 0.59,
    'tile_table.table_insert_many': 0.53,
    'waves.downsample_2x2': 0.53,
    'tile_table.table_remove': 0.49,
    'waves.slopes_from_heights': 0.47,
    'placement.drop_unseen': 0.43,
    'surface_tiles.leaf_standins': 0.42,
    'tile_table.mark_used': 0.36,
    'obstacles.select_obstacle_points': 0.35,
    'tile_table.table_rehash': 0.34,
    'placement.place_particles': 0.33,
    'lifecycle.age_particles': 0.31,
    'tile_table.table_find_many': 0.31,
    'raycast.pyramid_size': 0.26,
    'placement.select_new_on_ground': 0.25,
    'waves.gradients_3d': 0.24,
    'waves.gradients_2d': 0.24,
    'tile_table.codes_of': 0.23,
    'tile_table.table_find': 0.22,
    'rain.drops_this_frame': 0.19,
    'sprites.slot_span': 0.15,
    '_jit.is_finite': 0.09,
    'tile_table.table_insert': 0.01,
}
