// Terrain tiles: ground shaded by slope, height and wetness, with procedural detail.
//
// Materials: grass (tones and dry patches at several scales, bare soil in places), rock on
// steep slopes, dry sand on the shore, wet sand just above the water line (darker, glossy),
// and under the water the river bed (silt in the deep, sand and pebbles in the shallows,
// darker with depth: the light that reaches the bed has crossed the water twice). Wetness
// comes from the height above the water level seen from the point and its distance to the
// shore (both per vertex, from the water tiles).
//
// Detail is world-space value noise (integer hashes: no repeat, exact far from the origin) in
// octaves; each octave fades to its mean where its wavelength shrinks under a few pixels (the
// footprint of a pixel on the ground, from the screen derivatives of the position): no
// shimmer. The noise's own gradient bumps the normal. Eight noise lookups a pixel in all: on
// Mesa's llvmpipe a hashed value noise costs a fraction of a texture tap, and every branch of
// a shader runs (masked), so the materials share these lookups rather than branch to their
// own.
#include "common.glsl"

#ifdef VERTEX
#include "flood.glsl"
layout(location = 0) in vec3 a_position;   // [m]
layout(location = 1) in vec3 a_normal;
layout(location = 2) in float a_level;     // water level seen from here [m] (-1e4: none near)
layout(location = 3) in float a_shore;     // distance to the shore [m], < 0 in the water, in
                                           // units of the river's size (scenes/meshes.py
                                           // river_scale: metres by rivers 8 m wide or more)
out vec3 v_world;
out vec3 v_normal;
out float v_level;
out float v_wet_level;
out float v_rise;
out float v_shore;
void main() {
    // a flood raises the level seen from here (issue 25): the ground below it is flooded
    vec2 flood = a_level > -1000.0 ? flood_at(a_position.xy) : vec2(0.0);
    v_world = a_position;
    v_normal = a_normal;
    v_level = a_level + flood.x;
    v_wet_level = a_level + flood.y;
    v_rise = flood.x;
    v_shore = a_shore;
    gl_Position = u_view_projection * vec4(a_position, 1.0);
    gl_ClipDistance[0] = u_clip_water > 0.0 ? a_position.z - v_level : 1.0;
}
#endif

#ifdef FRAGMENT
#include "water_look.glsl"
in vec3 v_world;
in vec3 v_normal;
in float v_level;
in float v_wet_level;
in float v_rise;
in float v_shore;
out vec4 frag;
uniform float u_clarity_m;      // the water's clarity [m] (DisplaySettings; a flood's water)
uniform bool u_debug_materials;  // tests: (rock, drawn slope / 90°, bed, 0.5) for the colour
#ifdef FLOOD_WAVES
// the program drawn while a flood is (systems/draw.py: a software rasteriser runs every
// branch, masked, so the dry ground's program has none of this)
#include "wave.glsl"
#include "params.glsl"
#include "sprite_waves.glsl"
// the flooded floodplain's surface (issue 25): 1 the world-fixed waves, 2 the wave sprites
// of its particles (the water's advected mode)
uniform int u_flood_waves;
uniform float u_slope_factor;   // the water's wave slopes' scale (DisplaySettings)
#endif

// -- detail -------------------------------------------------------------------------------

uint hash_u(ivec2 q) {
    uvec2 v = uvec2(q) * uvec2(1597334673u, 3812015801u);
    uint n = (v.x ^ v.y) * 1597334673u;
    return n ^ (n >> 16);
}

float hash(ivec2 q) {
    return float(hash_u(q)) * (1.0 / 4294967295.0);
}

// Value noise in [0, 1]: hashed lattice values, quintic interpolation.
float noise(vec2 p) {
    vec2 f = fract(p);
    ivec2 i = ivec2(floor(p));
    vec2 u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    float a = hash(i), b = hash(i + ivec2(1, 0)), c = hash(i + ivec2(0, 1));
    float d = hash(i + ivec2(1, 1));
    return mix(mix(a, b, u.x), mix(c, d, u.x), u.y);
}

// The same with its gradient (per unit of p): (value, d/dx, d/dy).
vec3 noise_d(vec2 p) {
    vec2 f = fract(p);
    ivec2 i = ivec2(floor(p));
    vec2 u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    vec2 du = 30.0 * f * f * (f * (f - 2.0) + 1.0);
    float a = hash(i), b = hash(i + ivec2(1, 0)), c = hash(i + ivec2(0, 1));
    float d = hash(i + ivec2(1, 1));
    float k = a - b - c + d;
    return vec3(a + (b - a) * u.x + (c - a) * u.y + k * u.x * u.y,
                du * vec2(b - a + k * u.y, c - a + k * u.x));
}

const mat2 TURN_A = mat2(0.7986, 0.6018, -0.6018, 0.7986);    // 37°
const mat2 TURN_B = mat2(0.2588, -0.9659, 0.9659, 0.2588);    // -75°

// An octave of wavelength wl_m at p (turned by `turn`): value and gradient [1/m], faded to
// the mean (0.5, flat) between 6 and 2 pixels of wavelength.
vec3 octave(vec2 p_m, mat2 turn, float wl_m, float footprint_m) {
    float keep = clamp((wl_m / footprint_m - 2.0) * 0.25, 0.0, 1.0);
    if (keep <= 0.0) return vec3(0.5, 0.0, 0.0);
    vec3 n = noise_d(turn * p_m / wl_m);
    return vec3(mix(0.5, n.x, keep), keep * (n.yz * turn) / wl_m);
}

// Three octaves from wavelength wl_m down (halved and turned each time): value in [0, 1] and
// its gradient [1/m].
vec3 fbm3(vec2 p_m, float wl_m, float footprint_m) {
    return (4.0 * octave(p_m, mat2(1.0), wl_m, footprint_m)
            + 2.0 * octave(p_m + 31.7, TURN_A, 0.5 * wl_m, footprint_m)
            + octave(p_m - 17.3, TURN_B, 0.25 * wl_m, footprint_m)) / 7.0;
}

// -- materials ------------------------------------------------------------------------------

const vec3 GRASS_DARK = vec3(0.21, 0.33, 0.12);
const vec3 GRASS_LIGHT = vec3(0.35, 0.44, 0.17);
const vec3 GRASS_DRY = vec3(0.52, 0.50, 0.29);
const vec3 SOIL = vec3(0.37, 0.30, 0.21);
const vec3 ROCK_DARK = vec3(0.36, 0.35, 0.33);
const vec3 ROCK_LIGHT = vec3(0.58, 0.55, 0.50);
const vec3 SAND_DRY = vec3(0.72, 0.65, 0.49);
const vec3 SAND_WET = vec3(0.40, 0.35, 0.26);
const vec3 SILT = vec3(0.34, 0.32, 0.25);
const vec3 BED_SAND = vec3(0.50, 0.45, 0.34);

void main() {
    vec3 n0 = normalize(v_normal);
    vec2 p = v_world.xy;
    // the size of a pixel on the ground [m], longest across: from the distance, the pixel's
    // angle (cot(fov/2) is the length of the projection's second row) and the incidence;
    // continuous across triangles (the screen derivatives jump at their edges)
    vec3 to_eye = u_eye_m - v_world;
    float cot_half_fov = length(vec3(u_view_projection[0][1], u_view_projection[1][1],
                                     u_view_projection[2][1]));
    float pixel = 2.0 / (cot_half_fov * u_viewport_px.y);
    float footprint = max(length(to_eye) * pixel / max(abs(dot(normalize(to_eye), n0)), 0.2),
                          1e-3);
    bool river = v_level > -1000.0;             // a river within reach: shores, bed
    float above = river ? v_world.z - v_level : 1e3;   // height above the water [m]
    float shore = river ? v_shore : 1e3;        // distance to the shore [m], < 0 in the water
    float slope = 1.0 - n0.z;                   // 0 flat … 1 vertical

    // large-scale patches (90 m, 30 m), the ground's detail (6 m → 1.5 m) and its grain
    // (0.6 m → 0.15 m: tufts, blades, grains of sand), each with its own contrast
    float patches = 0.65 * noise(p / 90.0) + 0.35 * noise(TURN_B * p / 30.0 + 7.1);
    vec3 detail_d = fbm3(p, 6.0, footprint);
    vec3 grain_d = fbm3(p + 5.3, 0.6, footprint);
    float detail = detail_d.x, grain = grain_d.x;
    float tone = smoothstep(0.2, 0.8, detail);
    vec3 albedo = mix(GRASS_DARK, GRASS_LIGHT, tone) * (0.75 + 0.5 * grain);
    albedo = mix(albedo, GRASS_DRY, smoothstep(0.5, 0.85, patches) * 0.4);
    float bare = smoothstep(0.74, 0.84, patches * 0.55 + detail * 0.45);
    albedo = mix(albedo, SOIL * (0.8 + 0.4 * detail), bare * 0.35);
    vec2 relief = 0.25 * detail_d.yz + 0.06 * grain_d.yz;   // slopes of the detail as relief

    // rock where the ground is steep (its edge broken by the patches): layered, cracked
    float rock = smoothstep(0.16, 0.28, slope + (patches - 0.5) * 0.12);
    {   // (no noise of its own: a software rasteriser runs every branch)
        // layers 4 m apart, bent by the detail, faded where they come closer than 12 pixels
        // (how fast the height changes across the screen: a cliff seen from afar)
        float layers = clamp((4.0 / max(fwidth(v_world.z), 1e-3) - 6.0) / 6.0, 0.0, 1.0);
        float strata = 0.5 + 0.5 * layers * sin(6.2832 * fract(v_world.z * 0.25) + detail * 5.0);
        vec3 stone = mix(ROCK_DARK, ROCK_LIGHT, clamp(detail * 0.8 + strata * 0.4 - 0.1, 0.0, 1.0));
        albedo = mix(albedo, stone * (0.8 + 0.4 * grain), rock);
        relief = mix(relief, 1.2 * detail_d.yz + 0.3 * grain_d.yz, rock);
    }

    // the shore: sand from the water up to a width that wanders along it, from a strip to a
    // beach of several metres (its edge broken by the grass; in the river's units: a creek's
    // beach is of its own size), wet just above the water
    float width = mix(0.5, 7.0, smoothstep(0.3, 0.7, patches)) + (detail - 0.5) * 2.5;
    float beach = (1.0 - smoothstep(width, width + 1.5, shore))
                  * (1.0 - smoothstep(1.2, 2.0, above + 0.5 * (detail - 0.5)));
    beach *= 1.0 - rock * 0.7;
    vec3 sand = SAND_DRY * (0.88 + 0.16 * detail + 0.14 * grain);
    albedo = mix(albedo, sand, beach);
    relief = mix(relief, 0.05 * detail_d.yz + 0.015 * grain_d.yz, beach);
    float wet = 1.0 - smoothstep(0.05, 0.45, above + 0.15 * (detail - 0.5));
    // ground a flood covered stays wet-looking a while (v_wet_level lags the falling level)
    float above_wet = river ? v_world.z - v_wet_level : 1e3;
    wet = max(wet, 1.0 - smoothstep(0.0, 0.3, above_wet + 0.1 * (detail - 0.5)));

    // the river bed under the water: sand and pebbles in the shallows, silt in the deep,
    // darker with depth (light down to the bed and back up)
    float depth = max(-above, 0.0);
    float under = 1.0 - smoothstep(-0.12, 0.02, above);
    {
        vec3 bed = mix(BED_SAND, SILT, smoothstep(0.3, 2.0, depth + (patches - 0.5)));
        bed *= 0.75 + 0.3 * detail + 0.2 * grain;
        // pebbles: the grain's high spots, in the shallows, brighter or darker by the detail
        float stone = smoothstep(0.58, 0.64, grain) * (1.0 - smoothstep(0.8, 2.4, depth));
        vec3 tint = mix(vec3(0.34, 0.32, 0.30), vec3(0.70, 0.64, 0.54), fract(detail * 7.0));
        bed = mix(bed, tint, stone * 0.8);
        bed *= exp(-0.18 * depth) * vec3(0.92, 0.98, 1.0);
        albedo = mix(albedo, bed, under);
        relief = mix(relief, 0.5 * relief + 0.2 * stone * grain_d.yz, under);
    }
    albedo = mix(albedo, albedo * 0.5, wet * (1.0 - under));    // wet ground is darker

    // light: the relief bumps the normal; wet ground shines
    vec3 n = normalize(n0 - vec3(relief, 0.0));
    float sun = max(dot(n, u_sun_dir), 0.0);
    vec3 light = SUN_COLOUR * sun * 0.95 + vec3(0.32, 0.38, 0.46) * (0.5 + 0.5 * n.z);
    vec3 colour = albedo * light;
    vec3 h = normalize(normalize(to_eye) + u_sun_dir);
    colour += SUN_COLOUR * (wet * (1.0 - under) * 0.35) * pow(max(dot(n, h), 0.0), 40.0);
    // a flood (issue 25) over the ground below its level (the floodplain, and the channel's
    // banks and bed: the raised water mesh need not cover them, far tiles' coarse meshes
    // leave strips along the old banks) shaded by the river's water's own model
    // (water_look.glsl: the sky's Fresnel reflection, the sun's glint, the deep colour over
    // the ground seen through water of the same clarity), so that it meets the channel's
    // water across the old bank without a seam. At the flood's edge the depth fades the
    // water's look out over its last 0.5 m as at the river's shore: no hard line where the
    // level meets the ground (dry ground: no water, and no wave sprites read)
    float plain = depth > 0.0 ? smoothstep(0.0, 0.05, v_rise) : 0.0;
    vec3 e = normalize(to_eye);
    // a surface the ground's grain ruffles, or (FLOOD_WAVES) the water's waves at the point
    // of its surface on this pixel's line of sight, carried by the particles on the flooded
    // ground in the advected mode (sprite_waves.glsl; the grid read only where it is drawn)
    vec2 tilt = 0.05 * grain_d.yz + 0.02 * detail_d.yz;
#ifdef FLOOD_WAVES
    vec2 q = p + e.xy * (depth / max(e.z, 0.1));
    vec2 quv = q / max(u_wave_length_m, 1e-3);
    vec2 quv_dx = dFdx(quv), quv_dy = dFdy(quv);
    if (plain > 0.0)     // (a software rasteriser runs it masked: the dry lanes list none)
        tilt = u_slope_factor * sprite_wave_slopes(
            q, quv_dx, quv_dy, plain > 0.0 && u_flood_waves > 1 ? MAX_PER_CELL : 0);
#endif
    {
        vec3 nw = normalize(vec3(-tilt, 1.0));
        float edge = smoothstep(0.0, 0.5, depth);        // the water's shore fade (water.glsl)
        float fresnel = water_fresnel(e, nw, edge);
        vec3 r = reflect(-e, nw);
        r.z = abs(r.z);
        vec4 look = water_look(e, nw, sky_colour(r), fresnel, edge, depth, u_clarity_m);
        colour = mix(colour, look.rgb + look.a * colour, plain);
    }
    frag = vec4(apply_fog(colour, v_world), 1.0);
    if (u_debug_materials) {   // uniform: derivatives stay defined
        vec3 facet = normalize(cross(dFdx(v_world), dFdy(v_world)));
        frag = vec4(rock, acos(clamp(abs(facet.z), 0.0, 1.0)) / 1.5707963, under, 0.5);
    }
}
#endif
