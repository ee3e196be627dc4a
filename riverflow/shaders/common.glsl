// Shared by the programs: smooth fade, sky, sun and fog. Numbers that Python also uses arrive
// as #defines (riverflow.engine.gl.enum_defines): FLOW_STATUS_*, DISPLAY_MODE_*, ...

// The view: one uniform block (std140) for every program, written once a frame for the main
// passes and once for the reflection's mirrored one and bound before each (the offsets are
// those that riverflow.systems.draw.pack_view writes; include this file once a program).
layout(std140) uniform View {
    mat4 u_view_projection;    // world -> clip                              offset   0
    mat4 u_world_from_clip;    // the camera's clip -> world                 offset  64
    vec3 u_eye_m;              // camera position [m]                        offset 128
    float u_fog_density;       // exponential fog [1/m]                      offset 140
    vec3 u_sun_dir;            // unit vector towards the sun                offset 144
    float u_clip_water;        // 1: the reflection pass, cut what is under  offset 156
                               // the water (terrain, props)
    vec2 u_viewport_px;        // the target's size [px]                     offset 160
};

const vec3 SUN_COLOUR = vec3(1.0, 0.93, 0.80);
const vec3 FOG_COLOUR = vec3(0.72, 0.79, 0.87);

// 6t^5 - 15t^4 + 10t^3 on [0, 1], clamped (Proland's f, never negative).
float fade5(float t) {
    t = clamp(t, 0.0, 1.0);
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

// Radiance of the sky seen along the unit direction dir (world, z up).
vec3 sky_colour(vec3 dir) {
    float h = dir.z;
    vec3 horizon = vec3(0.74, 0.82, 0.91);
    vec3 zenith = vec3(0.22, 0.43, 0.78);
    vec3 c = mix(horizon, zenith, sqrt(clamp(h, 0.0, 1.0)));
    c = mix(c, vec3(0.52, 0.57, 0.62), clamp(-h * 4.0, 0.0, 1.0));
    float s = max(dot(dir, u_sun_dir), 0.0);
    return c + SUN_COLOUR * (0.25 * pow(s, 8.0));
}

float fog_amount(vec3 world_m) {
    return 1.0 - exp(-length(world_m - u_eye_m) * u_fog_density);
}

vec3 apply_fog(vec3 colour, vec3 world_m) {
    return mix(colour, FOG_COLOUR, fog_amount(world_m));
}
