// Spills (issue 24): the water discoloured by the tracers the spill solver carries down the
// network. In the normal look the wave sprites carry it: each particle holds the spills'
// colour and concentration where it sampled them (riverflow.kernels.spill.sample_tint; the
// sprite table's texel 3: c and the colour packed 8 bits a channel), and the water shader
// blends them with the sprites' own weights (water.glsl blend_sprites), mixing the spill's
// colour into the water by 0.75 (1 - exp(-c / u_spill_visible)) per sprite.
// The "concentration" display mode (a measurement view) samples u_spill, an RGBA32F texture
// over the square u_spill_rect = (x0, y0, side) [m] of the world (riverflow.hydro.spills.
// SpillTint: RGB the spills' mean colour there, A the total concentration [kg/m3]; u_spill_on
// = 0 when there is no spill) and shows log10(c) on a colour ramp over u_spill_range (log10 of
// the lowest and highest concentration shown [kg/m3]).
uniform sampler2D u_spill;
uniform vec3 u_spill_rect;
uniform int u_spill_on;
uniform float u_spill_visible;
uniform vec2 u_spill_range;

// (rgb, concentration [kg/m3]) at a world point; 0 outside the texture's square.
vec4 spill_at(vec2 xy) {
    if (u_spill_on == 0) return vec4(0.0);
    vec2 uv = (xy - u_spill_rect.xy) / u_spill_rect.z;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return vec4(0.0);
    return texture(u_spill, uv);
}

// How much of the water's colour a spill of concentration c [kg/m3] replaces (normal look).
float spill_cover(float c) {
    return c > 0.0 ? 0.75 * (1.0 - exp(-c / u_spill_visible)) : 0.0;
}

// A sprite's spill colour, packed as r * 65536 + g * 256 + b (0..255 each, an exact float).
vec3 spill_unpack(float rgb) {
    float r = floor(rgb / 65536.0);
    float g = floor((rgb - r * 65536.0) / 256.0);
    return vec3(r, g, rgb - r * 65536.0 - g * 256.0) / 255.0;
}

// The colour ramp of the concentration mode (also the legend's): dark water below the range,
// then blue, cyan, green, yellow, red over log10(c) in u_spill_range.
vec3 concentration_ramp(float t) {
    vec3 a = vec3(0.05, 0.15, 0.60), b = vec3(0.05, 0.70, 0.80), c = vec3(0.20, 0.80, 0.20);
    vec3 d = vec3(0.95, 0.85, 0.10), e = vec3(0.85, 0.10, 0.05);
    t = clamp(t, 0.0, 1.0) * 4.0;
    if (t < 1.0) return mix(a, b, t);
    if (t < 2.0) return mix(b, c, t - 1.0);
    if (t < 3.0) return mix(c, d, t - 2.0);
    return mix(d, e, t - 3.0);
}

vec3 concentration_colour(vec4 s) {
    if (s.a <= pow(10.0, u_spill_range.x)) return vec3(0.02, 0.05, 0.16);
    return concentration_ramp((log(s.a) / log(10.0) - u_spill_range.x)
                              / (u_spill_range.y - u_spill_range.x));
}
