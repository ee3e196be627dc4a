// Test probe: standing_slopes (rapids.glsl) at one world point per pixel: u_points (RGBA32F)
// holds x, y [m] and the surface's level gradient (gx, gy) [m/m]; u_px_m a pixel's size [m].
#include "rapids.glsl"
uniform sampler2D u_points;
uniform float u_px_m;

#ifdef VERTEX
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT
out vec4 frag;
void main() {
    vec4 q = texelFetch(u_points, ivec2(gl_FragCoord.xy), 0);
    float crest;
    vec2 s = standing_slopes(q.xy, q.zw, u_px_m, crest);
    frag = vec4(s, crest, 1.0);
}
#endif
