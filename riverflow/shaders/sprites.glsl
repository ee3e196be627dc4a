// Pre-advected mode, pass 1: each INSIDE/LEAVING particle is a screen-aligned quad of half
// size 3r; every water pixel under it adds (w·slope.x, w·slope.y, w², w) to a float target
// (additive blending). The water shader then divides by sqrt(sum w²), with the world-fixed
// waves joining where sum w < 1 (water.glsl covered_slopes).
#include "common.glsl"
#include "params.glsl"
uniform float u_sprite_radius_factor;

#ifdef VERTEX
flat out vec4 v_p0;
flat out vec4 v_p1;
const vec2 CORNERS[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1),
                                vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
void main() {
    int slot = gl_VertexID / 6;
    v_p0 = sprite_param(slot, 0);
    v_p1 = sprite_param(slot, 1);
    vec4 p2 = sprite_param(slot, 2);
    if (!sprite_drawn(p2.x, v_p1.z)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);   // outside the clip volume: nothing drawn
        return;
    }
    vec2 px = v_p0.xy + CORNERS[gl_VertexID % 6] * v_p1.w * u_sprite_radius_factor;
    gl_Position = vec4(px / u_viewport_px * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT
#include "wave.glsl"
uniform sampler2D u_water_position;   // world position of the visible water, a = 0 elsewhere
flat in vec4 v_p0;
flat in vec4 v_p1;
out vec4 frag;
void main() {
    vec4 water = texelFetch(u_water_position, ivec2(gl_FragCoord.xy), 0);
    vec2 uv0 = water.xy / u_wave_length_m;
    vec2 uv_dx = dFdx(uv0), uv_dy = dFdy(uv0);    // before any discard (derivatives need quads)
    float s = length(gl_FragCoord.xy - v_p0.xy) / (v_p1.w * u_sprite_radius_factor);
    if (water.a == 0.0 || s >= 1.0) discard;
    float w = fade5(1.0 - s) * fade5(v_p1.z);
    vec2 slopes = wave_slopes((water.xy - v_p0.zw + v_p1.xy) / u_wave_length_m, uv_dx, uv_dy);
    frag = vec4(w * slopes, w * w, w);
}
#endif
