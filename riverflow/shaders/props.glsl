// Props (boats, barrels): flat-shaded coloured triangles placed by a model matrix, lit by the
// sun and the sky, fogged like the terrain.
#include "common.glsl"
uniform mat4 u_view_projection;
uniform mat4 u_model;
uniform float u_clip_water;     // 1: the reflection pass, cut what is under the waterline...
uniform float u_clip_level_m;   // ... at this height [m]

#ifdef VERTEX
layout(location = 0) in vec3 a_position;   // model frame [m]
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_colour;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_colour;
void main() {
    vec4 world = u_model * vec4(a_position, 1.0);
    v_world = world.xyz;
    v_normal = mat3(u_model) * a_normal;
    v_colour = a_colour;
    gl_Position = u_view_projection * world;
    gl_ClipDistance[0] = u_clip_water > 0.0 ? world.z - u_clip_level_m : 1.0;
}
#endif

#ifdef FRAGMENT
in vec3 v_world;
in vec3 v_normal;
in vec3 v_colour;
out vec4 frag;
void main() {
    vec3 n = normalize(v_normal);
    float sun = max(dot(n, u_sun_dir), 0.0);
    vec3 light = SUN_COLOUR * sun * 0.9 + vec3(0.35, 0.40, 0.48) * (0.6 + 0.4 * n.z);
    frag = vec4(apply_fog(v_colour * light, v_world), 1.0);
}
#endif
