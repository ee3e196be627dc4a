// Test probe: writes what the shaders read from the sprite tables, one value set per pixel.
// u_what 0..2: sprite table texel 0..2 of entry y * width + x; 3: the bins texel (x, y) (as
// float; the bins are u_width texels a row).
#include "params.glsl"
uniform int u_what;
uniform int u_width;            // of the probe target [px]
uniform isamplerBuffer u_bins;

#ifdef VERTEX
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT
out vec4 frag;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    if (u_what < 3) {
        frag = sprite_param(px.y * u_width + px.x, u_what);
    } else {
        frag = vec4(float(texelFetch(u_bins, px.y * u_width + px.x).r), 0.0, 0.0, 1.0);
    }
}
#endif
