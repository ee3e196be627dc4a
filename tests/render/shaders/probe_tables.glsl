// Test probe: writes what the shaders read from the sprite tables, one value set per pixel.
// u_what 0..2: parameter texel 0..2 of slot y * width + x; 3: the k-th slot of cell (x / 16, y)
// with k = x % 16 (as float).
#include "params.glsl"
uniform int u_what;
uniform int u_width;            // of the probe target [px]
uniform isampler2D u_grid;

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
        int k = px.x % MAX_PER_CELL;
        ivec4 ids = texelFetch(u_grid, ivec2(4 * (px.x / MAX_PER_CELL) + k / 4, px.y), 0);
        frag = vec4(float(ids[k % 4]), 0.0, 0.0, 1.0);
    }
}
#endif
