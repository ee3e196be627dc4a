// The water surface: the water mesh at the water level, shaded from the wave slopes that the
// display mode picks (sprite blending, pre-advected sums, plain texture, debug colours).
// With POSITION_PASS defined it only writes the surface's world position (pre-advected mode).
#include "common.glsl"

#ifdef VERTEX
#include "flood.glsl"
layout(location = 0) in vec3 a_position;   // (x, y, water level) [m]
layout(location = 1) in float a_ground;    // the terrain (river bed) under it [m]
out vec3 v_world;
out float v_ground;
void main() {
    v_world = a_position + vec3(0.0, 0.0, flood_rise(a_position.xy));   // a flood's rise
    v_ground = a_ground;
    gl_Position = u_view_projection * vec4(v_world, 1.0);
}
#endif

#ifdef FRAGMENT
in vec3 v_world;
in float v_ground;
out vec4 frag;

#ifdef POSITION_PASS
void main() {
    frag = vec4(v_world, 1.0);
}
#else
#include "wave.glsl"
#include "params.glsl"
#include "ripples.glsl"
#include "reflection.glsl"
#include "foam.glsl"
#include "wake.glsl"
#include "rapids.glsl"
#include "spill.glsl"
#include "water_look.glsl"

#include "sprite_waves.glsl"

uniform int u_mode;                 // DISPLAY_MODE_*
uniform bool u_show_grid;
uniform sampler2D u_accum;          // pre-advected sums (w·slope.x, w·slope.y, w², w)
uniform float u_slope_factor;
uniform float u_clarity_m;

// Blend the sprites listed in this pixel's cell: returns (A.x, A.y, B = sum w^2, covering);
// weight = sum w (advected mode; the number of sprites covering the pixel in the others).
// full = the cell's list holds MAX_PER_CELL particles. foam (advected and foam modes): the
// sprites' foam amount (sum w f / max(sum w, 1): their weighted mean, fading out with the
// coverage where sum w < 1), then for their lace patterns (foam.glsl; advected mode) sum
// w (lace - 0.5), sum w^2 and sum w over the sprites with foam (foam_lace_at). tint
// (advected mode): the spills' discolouring the sprites carry, sum w cover rgb and sum w cover
// (cover = spill_cover(c) of each sprite's concentration c, rgb its spill colour).
vec4 blend_sprites(vec2 uv_dx, vec2 uv_dy, out bool full, out vec4 foam, out float weight,
                   out vec4 tint) {
    ivec2 cell = sprite_cell();
    vec2 A = vec2(0.0);
    float B = 0.0;
    float covering = 0.0;
    float S = 0.0;
    float S_lace = 0.0;                 // sum w of the sprites with foam
    tint = vec4(0.0);
    int listed = 0;
    // foam: sum w, sum w f, sum w (lace - 0.5) and its sum w^2; the lace's uv derivatives
    vec4 F = vec4(0.0);
    float scale = u_wave_length_m / u_foam_scale_m;
    vec2 fuv_dx = uv_dx * scale, fuv_dy = uv_dy * scale;
    for (int t = 0; t < MAX_PER_CELL / 4; ++t) {
        ivec4 ids = texelFetch(u_grid, ivec3(cell, t), 0);
        for (int k = 0; k < 4; ++k) {
            int id = ids[k];
            if (id < 0) { t = MAX_PER_CELL; break; }
            ++listed;
            vec4 p0 = sprite_param(id, 0);
            vec4 p1 = sprite_param(id, 1);
            if (p1.z <= 0.0) continue;     // a slot written free (non-finite world position)
            float s = length(gl_FragCoord.xy - p0.xy) / (p1.w * u_sprite_radius_factor);
            if (s < 1.0) {
                covering += 1.0;
                if (u_mode == DISPLAY_MODE_ADVECTED || u_mode == DISPLAY_MODE_FOAM) {
                    vec2 uv = (v_world.xy - p0.zw + p1.xy) / u_wave_length_m;
                    float w = fade5(1.0 - s) * fade5(p1.z);
                    vec4 p3 = sprite_param(id, 3);     // foam, spill c, spill colour
                    float f = p3.x;
                    F.xy += w * vec2(1.0, f);
                    if (u_mode == DISPLAY_MODE_FOAM) continue;
                    if (p3.y > 0.0) {
                        float cover = w * spill_cover(p3.y);
                        tint += vec4(cover * spill_unpack(p3.z), cover);
                    }
                    A += w * wave_slopes(uv, uv_dx, uv_dy);
                    B += w * w;
                    S += w;
                    if (f > FOAM_MIN) {
                        F.z += w * (foam_lace(uv * scale, fuv_dx, fuv_dy) - 0.5);
                        F.w += w * w;
                        S_lace += w;
                    }
                }
            }
        }
    }
    full = listed >= MAX_PER_CELL;
    weight = u_mode == DISPLAY_MODE_ADVECTED ? S : covering;
    foam = vec4(F.y / max(F.x, 1.0), F.zw, S_lace);
    return vec4(A, B, covering);
}

// The foam lace of a pixel from its sprites' sums (sum w (lace - 0.5), sum w^2, sum w) over
// the sprites with foam: their patterns blended with the contrast kept, joined by the lace
// fixed in the world (at fuv) with weight fade5(1 - sum w) as covered_slopes does the waves,
// so the lace does not change at once where the last such sprite's disc ends.
float foam_lace_at(vec3 sums, vec2 fuv, vec2 fuv_dx, vec2 fuv_dy) {
    float wl = fade5(1.0 - sums.z);
    if (wl > 0.0) {
        sums.x += wl * (foam_lace(fuv, fuv_dx, fuv_dy) - 0.5);
        sums.y += wl * wl;
    }
    return 0.5 + sums.x / sqrt(sums.y);
}

void main() {
    vec2 uv0 = v_world.xy / u_wave_length_m;
    vec2 uv_dx = dFdx(uv0), uv_dy = dFdy(uv0);
    float depth_m = max(v_world.z - v_ground, 0.0);

    if (u_mode == DISPLAY_MODE_MESH) {
        frag = vec4(apply_fog(vec3(0.10, 0.35, 0.75), v_world), 0.0);
        return;
    }
    if (u_mode == DISPLAY_MODE_CONCENTRATION) {             // spills: log10(c) on a ramp
        frag = vec4(apply_fog(concentration_colour(spill_at(v_world.xy)), v_world), 0.0);
        return;
    }
    bool full = false;
    vec2 slopes = vec2(0.0);
    float weight = 0.0;
    vec4 foam = vec4(0.0);                                 // amount, lace sums (blend_sprites)
    vec4 tint = vec4(0.0);                                 // the sprites' spill tint sums
    if (u_mode == DISPLAY_MODE_COVERAGE) {
        vec4 b = blend_sprites(uv_dx, uv_dy, full, foam, weight, tint);
        frag = vec4(min(b.w / float(MAX_PER_CELL), 1.0), b.w == 0.0 ? 1.0 : 0.0,
                    full ? 1.0 : 0.0, 0.0);
        return;
    } else if (u_mode == DISPLAY_MODE_FOAM) {              // the foam amount alone
        blend_sprites(uv_dx, uv_dy, full, foam, weight, tint);
        frag = vec4(mix(vec3(0.02, 0.05, 0.16), vec3(1.0), foam.x), 0.0);
        return;
    } else if (u_mode == DISPLAY_MODE_ADVECTED) {
        vec4 b = blend_sprites(uv_dx, uv_dy, full, foam, weight, tint);
        slopes = covered_slopes(b.xy, b.z, weight, uv0, uv_dx, uv_dy);
    } else if (u_mode == DISPLAY_MODE_PRE_ADVECTED) {
        vec4 a = texelFetch(u_accum, ivec2(gl_FragCoord.xy), 0);
        slopes = covered_slopes(a.xy, a.z, a.w, uv0, uv_dx, uv_dy);
    } else {
        slopes = wave_slopes(uv0, uv_dx, uv_dy);           // non-advected
    }

    // shading: Fresnel reflection of sky and sun, refraction of the bed drawn before
    vec2 tilt = slopes * u_slope_factor;
    float px_m = max(length(dFdx(v_world.xy)), length(dFdy(v_world.xy)));
    if (u_ripple_count > 0)                                 // rain: rings where drops land
        tilt += ripple_slopes(v_world.xy, px_m);
    float crest = 0.0;                                      // boats: Kelvin wakes
    if (u_wake_count > 0)
        tilt += wake_slopes(v_world.xy, px_m, crest);
    vec3 wx = dFdx(v_world), wy = dFdy(v_world);            // rapids: standing waves where
    vec3 facet = cross(wx, wy);                             // the surface is steep
    vec2 grad = abs(facet.z) > 1e-9 ? -facet.xy / facet.z : vec2(0.0);
    float rapid_crest = 0.0;
    if (u_rapids.x > 0.0)
        tilt += standing_slopes(v_world.xy, grad, px_m, rapid_crest);
    crest = max(crest, rapid_crest);
    vec3 n = normalize(vec3(-tilt, 1.0));
    vec3 v = normalize(u_eye_m - v_world);
    float shore = smoothstep(0.0, 0.5, depth_m);            // soft shore: fade in over 0.5 m
    float fresnel = water_fresnel(v, n, shore);
    vec3 r = reflect(-v, n);
    r.z = abs(r.z);
    vec3 reflected = reflected_scene(v_world, v, n, sky_colour(r), fresnel);  // + banks, props
    vec4 look = water_look(v, n, reflected, fresnel, shore, depth_m, u_clarity_m);
    float fog = fog_amount(v_world);
    vec3 added = look.rgb;
    float through = look.a;                                // share of the bed seen through
    // spills: turbid, coloured water (spill.glsl) hides the bed under its colour, carried by
    // the sprites (their weighted mean, fading out with the coverage where sum w < 1, as foam)
    float stain = tint.a / max(weight, 1.0);
    if (stain > 0.0) {
        vec3 lit = tint.rgb / tint.a * (0.3 + 0.7 * max(dot(n, u_sun_dir), 0.0));   // shaded
        added = mix(added, fresnel * reflected + (1.0 - fresnel) * lit, stain);
        through *= 1.0 - stain;
    }
    // foam: the particles' (advected mode), the waterline's and the wakes' breaking crests;
    // its lace the sprites', joined by the lace fixed in the world where they thin out
    float amount = max(max(foam.x, shoreline_foam(depth_m, foam.x)), u_crest_foam * crest);
    vec2 fuv = uv0 * (u_wave_length_m / u_foam_scale_m);
    vec2 fuv_dx = uv_dx * (u_wave_length_m / u_foam_scale_m);
    vec2 fuv_dy = uv_dy * (u_wave_length_m / u_foam_scale_m);
    float lace = amount > 0.0 ? foam_lace_at(foam.yzw, fuv, fuv_dx, fuv_dy) : 0.5;
    float cover = foam_cover(amount, lace, fuv_dx, fuv_dy) * smoothstep(0.0, 0.06, depth_m);
    added = mix(added, foam_colour(n), cover);              // foam: opaque, matte
    through *= 1.0 - cover;
    vec3 colour = (1.0 - fog) * added + fog * FOG_COLOUR * (1.0 - through);
    if (u_show_grid) {
        vec2 f = fract(gl_FragCoord.xy / u_grid_cell_px);
        if (any(greaterThan(abs(f - 0.5), vec2(0.4)))) colour += vec3(0.2);
        if (full) colour = mix(colour, vec3(0.0, 1.0, 0.0), 0.35);
    }
    frag = vec4(colour, through);
}
#endif
#endif
