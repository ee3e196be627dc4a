// Terrain tiles: lit ground coloured by slope and by its height above the nearest water.
#include "common.glsl"
uniform mat4 u_view_projection;
uniform float u_clip_water;    // 1: the reflection pass, cut what is under the water level

#ifdef VERTEX
layout(location = 0) in vec3 a_position;   // [m]
layout(location = 1) in vec3 a_normal;
layout(location = 2) in float a_level;     // water level seen from here [m] (-1e4: none near)
out vec3 v_world;
out vec3 v_normal;
out float v_level;
void main() {
    v_world = a_position;
    v_normal = a_normal;
    v_level = a_level;
    gl_Position = u_view_projection * vec4(a_position, 1.0);
    gl_ClipDistance[0] = u_clip_water > 0.0 ? a_position.z - a_level : 1.0;
}
#endif

#ifdef FRAGMENT
in vec3 v_world;
in vec3 v_normal;
in float v_level;
out vec4 frag;

float hash(vec2 p) {
    return fract(sin(dot(p, vec2(127.1, 311.7))) * 43758.5453);
}

float value_noise(vec2 p) {
    vec2 i = floor(p), f = fract(p);
    vec2 u = f * f * (3.0 - 2.0 * f);
    return mix(mix(hash(i), hash(i + vec2(1, 0)), u.x),
               mix(hash(i + vec2(0, 1)), hash(i + vec2(1, 1)), u.x), u.y);
}

void main() {
    vec3 n = normalize(v_normal);
    float above_m = v_world.z - v_level;       // height above the (nearest) water level
    float wet = step(-1000.0, v_level);        // a river near: shores and bed by height
    float patch = value_noise(v_world.xy / 37.0) * 0.6 + value_noise(v_world.xy / 9.0) * 0.4;
    vec3 grass = mix(vec3(0.26, 0.38, 0.15), vec3(0.38, 0.44, 0.20), patch);
    vec3 rock = mix(vec3(0.42, 0.40, 0.36), vec3(0.52, 0.49, 0.44), patch);
    vec3 sand = vec3(0.63, 0.57, 0.43);
    vec3 bed = mix(vec3(0.50, 0.45, 0.34), vec3(0.36, 0.33, 0.26), patch);
    vec3 albedo = mix(grass, rock, smoothstep(0.12, 0.32, 1.0 - n.z));
    // sandy banks up to ~1.5 m above the water, the carved bed below it
    float shore = wet * (1.0 - smoothstep(0.3, 1.5, above_m));
    albedo = mix(albedo, sand, shore);
    albedo = mix(albedo, bed, wet * (1.0 - smoothstep(-0.4, 0.1, above_m)));
    float sun = max(dot(n, u_sun_dir), 0.0);
    vec3 light = SUN_COLOUR * sun * 0.95 + vec3(0.32, 0.38, 0.46) * (0.5 + 0.5 * n.z);
    frag = vec4(apply_fog(albedo * light, v_world), 1.0);
}
#endif
