// Spray and mist at the falls' plunge pools (riverflow.kernels.spray): each particle a soft
// round sprite facing the camera, depth-tested against the ground and water, alpha-blended,
// fading in over the first tenth of its life and out after, growing as the mist spreads.
#include "common.glsl"
uniform sampler2D u_spray;      // texel (0, i): x, y, z [m], age / life; (1, i): size [m]
uniform vec3 u_right;           // the camera's right and up (world, unit)
uniform vec3 u_up;

#ifdef VERTEX
out vec2 v_corner;
out float v_alpha;
out vec3 v_world;
const vec2 CORNERS[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1),
                               vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
void main() {
    int i = gl_VertexID / 6;
    vec4 p = texelFetch(u_spray, ivec2(0, i), 0);
    float size = texelFetch(u_spray, ivec2(1, i), 0).x;
    vec2 c = CORNERS[gl_VertexID % 6];
    float u = p.w;
    v_alpha = smoothstep(0.0, 0.1, u) * pow(1.0 - u, 1.5);
    v_corner = c;
    v_world = p.xyz + 0.5 * size * (c.x * u_right + c.y * u_up);
    gl_Position = u_view_projection * vec4(v_world, 1.0);
}
#endif

#ifdef FRAGMENT
in vec2 v_corner;
in float v_alpha;
in vec3 v_world;
out vec4 frag;
void main() {
    float r2 = dot(v_corner, v_corner);
    if (r2 > 1.0) discard;
    float a = v_alpha * 0.6 * exp(-3.0 * r2);
    vec3 lit = vec3(0.88, 0.91, 0.94) * (0.7 + 0.3 * max(u_sun_dir.z, 0.0))
               + 0.15 * SUN_COLOUR * max(u_sun_dir.z, 0.0);
    frag = vec4(apply_fog(lit, v_world), a);
}
#endif
