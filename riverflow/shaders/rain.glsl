// Rain drops as short streaks (seed 002: a drop is a line segment along its velocity), one
// GL_LINES pair per drop from gl_VertexID. The drop table (RGBA32F): drop i at row
// i / DROPS_PER_ROW, texels 2 * (i % DROPS_PER_ROW) + 0: position [m], + 1: velocity [m/s].
#include "common.glsl"
uniform sampler2D u_drops;
uniform float u_streak_s;           // a streak is the path of the last u_streak_s seconds

#ifdef VERTEX
out vec3 v_world;
out float v_tail;
void main() {
    int drop = gl_VertexID / 2;
    float tail = float(gl_VertexID % 2);
    ivec2 at = ivec2(2 * (drop % DROPS_PER_ROW), drop / DROPS_PER_ROW);
    vec3 p = texelFetch(u_drops, at, 0).xyz;
    vec3 v = texelFetch(u_drops, at + ivec2(1, 0), 0).xyz;
    v_world = p - tail * u_streak_s * v;
    v_tail = tail;
    gl_Position = u_view_projection * vec4(v_world, 1.0);
}
#endif

#ifdef FRAGMENT
in vec3 v_world;
in float v_tail;
out vec4 frag;
void main() {
    vec3 c = apply_fog(vec3(0.82, 0.86, 0.92), v_world);
    frag = vec4(c, 0.55 * (1.0 - 0.7 * v_tail) * (1.0 - fog_amount(v_world)));
}
#endif
