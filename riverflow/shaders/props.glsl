// Props (boats, barrels): coloured triangles placed by a model matrix, lit by the sun and the
// sky, glossy surfaces (paint, glass) mirroring the sky with a Fresnel weight and showing the
// sun's highlight, fogged like the terrain.
#include "common.glsl"
uniform mat4 u_model;
uniform float u_clip_level_m;   // the reflection pass (u_clip_water): the waterline [m]

#ifdef VERTEX
layout(location = 0) in vec3 a_position;   // model frame [m]
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_colour;
layout(location = 3) in float a_gloss;     // 0 matt ... 1 glass
out vec3 v_world;
out vec3 v_normal;
out vec3 v_colour;
out float v_gloss;
void main() {
    vec4 world = u_model * vec4(a_position, 1.0);
    v_world = world.xyz;
    v_normal = mat3(u_model) * a_normal;
    v_colour = a_colour;
    v_gloss = a_gloss;
    gl_Position = u_view_projection * world;
    gl_ClipDistance[0] = u_clip_water > 0.0 ? world.z - u_clip_level_m : 1.0;
}
#endif

#ifdef FRAGMENT
in vec3 v_world;
in vec3 v_normal;
in vec3 v_colour;
in float v_gloss;
out vec4 frag;
void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(u_eye_m - v_world);
    if (dot(n, v) < 0.0) n = -n;               // a normal interpolated past the silhouette
    float sun = max(dot(n, u_sun_dir), 0.0);
    // sun, and a hemisphere of sky above and sunlit ground below (walls in the shade stay
    // light: a white hull in the shade is a pale blue-grey, not a dark one)
    vec3 ambient = mix(vec3(0.30, 0.30, 0.26), vec3(0.50, 0.56, 0.66), 0.5 + 0.5 * n.z);
    vec3 light = SUN_COLOUR * sun * 0.85 + ambient;
    float fresnel = v_gloss * (0.04 + 0.96 * pow(1.0 - max(dot(n, v), 0.0), 5.0));
    vec3 r = reflect(-v, n);
    vec3 sky = sky_colour(vec3(r.xy, abs(r.z)));
    vec3 h = normalize(v + u_sun_dir);
    float shine = mix(8.0, 256.0, v_gloss);
    float spec = v_gloss * pow(max(dot(n, h), 0.0), shine) * (shine + 8.0) / 64.0 * sun;
    vec3 colour = mix(v_colour * light, sky, max(fresnel, 0.25 * v_gloss * v_gloss))
                  + SUN_COLOUR * spec;
    frag = vec4(apply_fog(colour, v_world), 1.0);
}
#endif
