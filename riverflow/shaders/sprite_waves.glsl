// The wave sprites of a pixel: the sprite grid (sprite_lists.glsl: each screen cell of
// u_grid_cell_px lists up to MAX_PER_CELL entries of the sprite table, params.glsl) and the
// advected wave slopes the sprites covering the pixel blend to (Yu et al. 2009 §5). Read by
// the water (water.glsl, with foam and tint in the same loop) and by the flooded floodplain
// (terrain.glsl, issue 25: the waves alone). Needs common.glsl, wave.glsl and params.glsl
// included before it.
uniform isampler2DArray u_grid;     // sprite lists: cell (cx, cy) = texel (cx, cy) of layers 0..3
uniform float u_grid_cell_px;
uniform ivec2 u_grid_size;          // cells (gw, gh)
uniform float u_sprite_radius_factor;

// This pixel's cell of the sprite grid.
ivec2 sprite_cell() {
    return clamp(ivec2(gl_FragCoord.xy / u_grid_cell_px), ivec2(0), u_grid_size - 1);
}

// The advected wave slopes of a pixel from its sprites' sums A = sum w slope, B = sum w^2 and
// S = sum w, continuous where the sprites' coverage ends (issue 29). Sprites sum to
// A / sqrt(B): the variance-normalised blend of independent patterns (Yu et al. 2009 §5), RMS
// 1 whatever their number. Where they thin out (S < 1: the rim of the last disc, a particle
// fading in, a gap between particles), the world-fixed waves join as one more independent
// pattern of weight fade5(1 - S), in the same normalisation: at S = 0 they are the waves
// alone, from S = 1 on the sprites alone, and the RMS slope (the shade) is the same
// throughout. A hard switch where S reaches 0 drew a line along the coverage's jagged edge.
vec2 covered_slopes(vec2 A, float B, float S, vec2 uv0, vec2 uv_dx, vec2 uv_dy) {
    float wf = fade5(1.0 - S);
    if (wf > 0.0) {
        A += wf * wave_slopes(uv0, uv_dx, uv_dy);
        B += wf * wf;
    }
    return B > 0.0 ? A / sqrt(B) : vec2(0.0);
}

// The advected wave slopes at world point xy [m] of this pixel (the sprites' waves alone, as
// the water's advected mode blends them; uv_dx, uv_dy: the screen derivatives of xy /
// u_wave_length_m). `listed` = 0 skips the grid (no sprite is read): the world-fixed waves.
vec2 sprite_wave_slopes(vec2 xy, vec2 uv_dx, vec2 uv_dy, int listed) {
    ivec2 cell = sprite_cell();
    vec2 A = vec2(0.0);
    float B = 0.0;
    float S = 0.0;
    for (int t = 0; t < listed / 4; ++t) {
        ivec4 ids = texelFetch(u_grid, ivec3(cell, t), 0);
        for (int k = 0; k < 4; ++k) {
            int id = ids[k];
            if (id < 0) { t = MAX_PER_CELL; break; }
            vec4 p0 = sprite_param(id, 0);
            vec4 p1 = sprite_param(id, 1);
            if (p1.z <= 0.0) continue;     // a slot written free (non-finite world position)
            float s = length(gl_FragCoord.xy - p0.xy) / (p1.w * u_sprite_radius_factor);
            if (s < 1.0) {
                float w = fade5(1.0 - s) * fade5(p1.z);
                A += w * wave_slopes((xy - p0.zw + p1.xy) / u_wave_length_m, uv_dx, uv_dy);
                B += w * w;
                S += w;
            }
        }
    }
    return covered_slopes(A, B, S, xy / u_wave_length_m, uv_dx, uv_dy);
}
