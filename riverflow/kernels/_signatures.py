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
            "(float64, float64, float64, int64, int64, int64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), float64, A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(bool, 2, 'C'), A(float64, 3, 'C'), A(float32, 2, 'C'), A(uint8, 2, 'C'), A(int32, 3, 'C'), A(float32, 2, 'C'), A(float32, 2, 'C'))",
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
            "(float64, float64, float64, int64, int64, int64, A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), float64, A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(int32, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 2, 'C'), A(bool, 2, 'C'), A(float64, 3, 'C'), A(float32, 2, 'C'), A(uint8, 2, 'C'), A(int32, 3, 'C'), A(float32, 2, 'C'), A(float32, 2, 'C'))",
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
            "(int64, A(bool, 1, 'C'), A(int64, 1, 'C'), A(bool, 1, 'C'), A(float64, 2, 'C'), A(float32, 2, 'C'), A(uint8, 1, 'C'), A(float32, 2, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(float32, 1, 'C'), A(int64, 1, 'C'), Named(riverflow.kernels.foam.FoamParams, (float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, )), Named(riverflow.kernels.foam.FoamFlow, (Named(riverflow.kernels.flow.CachedTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), A(int64, 1, 'C'), A(int32, 1, 'C'), A(float32, 3, 'C'), A(uint8, 3, 'C'), A(int32, 4, 'C'), A(int64, 1, 'C'), A(uint8, 1, 'C'), )), A(float32, 3, 'C'), A(float32, 3, 'C'), int64, int64, Named(riverflow.kernels.falls.FallTable, (A(float64, 2, 'C'), A(float64, 2, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), A(float64, 1, 'C'), )), )), Named(riverflow.kernels.surface_tiles.SurfaceTiles, (float64, float64, float64, int64, A(int64, 1, 'C'), A(int32, 1, 'C'), int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), A(float32, 3, 'C'), float64, float64, A(int32, 1, 'C'), A(int32, 2, 'C'), A(float32, 4, 'C'), int64, )), Named(riverflow.kernels.foam.FoamSources, (A(float64, 2, 'C'), A(float32, 3, 'C'), )), Named(riverflow.kernels.foam.ScreenNeighbours, (float64, int64, int64, A(int32, 1, 'C'), A(int32, 2, 'C'), float64, )), float64, int64, int64, int64, A(int32, 1, 'C'))",
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
    'foam.update_foam': 26.11,
    'flow.build_flow_tile': 12.98,
    'raycast_tiles.cast_rays_onto_tiles': 11.05,
    'fillets.corner_fillets': 7.69,
    'poisson_fill.fill_poisson_holes': 6.59,
    'poisson_cull.cull_crowded_particles': 6.08,
    'flow.query_velocity': 4.33,
    'tile_cut.coarser_across': 3.88,
    'advection.check_outside_near_water': 3.37,
    'flow.sample_potential': 3.18,
    'rain.step_rain': 2.69,
    'sprites.build_sprite_tables': 2.40,
    'tile_cut.cut_standins': 2.39,
    'tile_cut.near_to_far': 2.24,
    'level_mix.mixed_levels': 2.19,
    'advection.move_particles': 2.07,
    'waves.perlin_frames_3d': 1.10,
    'advection.place_at_seen_water': 1.09,
    'spill.spill_steps': 1.05,
    'placement.pixel_rays': 1.00,
    'level_mix.nearest_samples': 0.99,
    'spill.sample_tint': 0.94,
    'surface_tiles.water_level_at': 0.93,
    'noise.fbm': 0.89,
    'view_tiles.select_view_tiles': 0.87,
    'screen.project_particles': 0.84,
    'flood.flood_steps': 0.84,
    'waves.perlin_tile_2d': 0.83,
    'raycast.fill_height_pyramid': 0.78,
    'centre_line.view_level': 0.68,
    'centre_line.nearest_level': 0.67,
    'centre_line.project_to_centre': 0.63,
    'obstacles.apply_obstacles': 0.62,
    'polyline.nearest_points': 0.62,
    'advection.apply_flow_status': 0.56,
    'poisson_fill.blocked_direction_table': 0.55,
    'spill.tint_texels': 0.54,
    'waves.permutation': 0.53,
    'fillets.outline': 0.50,
    'tile_cut.edge_parts': 0.46,
    'waves.ripple_heights': 0.43,
    'wake.pack_trail': 0.40,
    'wake.advance_trail': 0.38,
    'flood.scale_by_cells': 0.35,
    'tile_table.table_remove': 0.31,
    'waves.downsample_2x2': 0.31,
    'flood.sample_by_cells': 0.31,
    'surface_tiles.leaf_standins': 0.29,
    'waves.slopes_from_heights': 0.29,
    'tile_table.mark_used': 0.26,
    'obstacles.select_obstacle_points': 0.23,
    'tile_table.table_insert_many': 0.23,
    'lifecycle.age_particles': 0.17,
    'placement.drop_unseen': 0.17,
    'tile_table.table_find_many': 0.17,
    'waves.gradients_2d': 0.17,
    'tile_table.table_rehash': 0.17,
    'waves.gradients_3d': 0.16,
    'raycast.pyramid_size': 0.14,
    'tile_table.codes_of': 0.14,
    'placement.place_particles': 0.14,
    'tile_table.table_find': 0.13,
    'rain.drops_this_frame': 0.12,
    'placement.select_new_on_ground': 0.10,
    'sprites.slot_span': 0.09,
    '_jit.is_finite': 0.07,
    'tile_table.table_insert': 0.00,
}
