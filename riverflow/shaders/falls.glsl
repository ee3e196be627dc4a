// The falling sheets (riverflow.scenes.fall_sheets): each fall's ribbon from its lip down the
// nappe to the pool, alpha-blended over the water and the ground drawn before it.
//
// Its streaks are a pattern fixed to the water: read at (across [m], tau = now - t), t the
// time since the lip, so each row of the pattern left the lip at one moment and falls with
// the water (downward at its speed; rows that left dt apart lie v*dt apart, so the streaks
// stretch as it speeds up: v = sqrt(v0^2 + 2 g d)). Translucent where the lip ends and where
// the streaks thin out, whiter as the falling water takes in air (with the time fallen).
#include "common.glsl"
uniform float u_time_s;
uniform float u_depth_pull_m;   // the foot's pull towards the eye in the depth test
uniform float u_clip_level_m;   // the reflection pass (u_clip_water): the mirror's level [m]

#ifdef VERTEX
layout(location = 0) in vec3 a_position;   // world [m]
layout(location = 1) in vec4 a_sheet;      // across [m], t [s], speed [m/s], edge [m]
layout(location = 2) in float a_fallen;    // t / the fall time
out vec3 v_world;
out vec4 v_sheet;
void main() {
    v_world = a_position;
    v_sheet = a_sheet;
    // the foot is drawn over the water mesh's coarse chord that runs on past the landing
    // (riverflow.scenes.fall_sheets.SHEET_DEPTH_PULL_M): the depth it is tested at is pulled
    // towards the eye, not where it is drawn
    vec3 to_eye = u_eye_m - a_position;
    float pull = min(u_depth_pull_m * a_fallen, 0.5 * length(to_eye));
    vec4 pulled = u_view_projection * vec4(a_position + pull * normalize(to_eye), 1.0);
    vec4 clip = u_view_projection * vec4(a_position, 1.0);
    gl_Position = vec4(clip.xy, pulled.z / pulled.w * clip.w, clip.w);
    gl_ClipDistance[0] = u_clip_water > 0.0 ? a_position.z - u_clip_level_m : 1.0;
}
#endif

#ifdef FRAGMENT
in vec3 v_world;
in vec4 v_sheet;
out vec4 frag;

const float STREAK_M = 0.35;    // streak width across the lip [m]
const float STREAK_S = 0.22;    // a streak's length in time [s] (v * this in metres)

float hash(vec2 p) {
    p = fract(p * vec2(0.1031, 0.1030));
    p += dot(p, p.yx + 33.33);
    return fract((p.x + p.y) * p.x);
}

float value_noise(vec2 p) {
    vec2 i = floor(p), f = fract(p);
    vec2 s = f * f * (3.0 - 2.0 * f);
    return mix(mix(hash(i), hash(i + vec2(1.0, 0.0)), s.x),
               mix(hash(i + vec2(0.0, 1.0)), hash(i + vec2(1.0, 1.0)), s.x), s.y);
}

// The streak pattern in [0, 1] at (across [m], tau [s]): two octaves of value noise.
float streaks(float across_m, float tau_s) {
    vec2 p = vec2(across_m / STREAK_M, tau_s / STREAK_S);
    return 0.5 * value_noise(p) + 0.3 * value_noise(vec2(2.3, 3.1) * p + vec2(17.0, 5.0))
           + 0.2 * value_noise(vec2(0.7, 5.3) * p + vec2(3.0, 41.0));
}

void main() {
    float t = v_sheet.y;
    float tau = mod(u_time_s - t, 600.0);          // (u_time_s wraps at an hour)
    float s = streaks(v_sheet.x, tau);
    float air = smoothstep(0.0, 0.9, t);           // breaking up as it falls
    float edge = smoothstep(0.0, 0.8, v_sheet.w);  // thin at the lip's ends
    float thick = edge * (0.45 + 0.55 * s);
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    vec3 v = normalize(u_eye_m - v_world);
    if (dot(n, v) < 0.0) n = -n;
    float cos_v = max(dot(n, v), 0.0);
    float fresnel = 0.02 + 0.98 * pow(1.0 - cos_v, 5.0);
    vec3 r = reflect(-v, n);
    vec3 water = mix(vec3(0.06, 0.22, 0.25) * (0.5 + 0.5 * max(u_sun_dir.z, 0.0)),
                     sky_colour(vec3(r.xy, abs(r.z))), fresnel);
    float lit = 0.55 + 0.45 * max(dot(n, u_sun_dir), 0.0) + 0.25 * max(u_sun_dir.z, 0.0);
    vec3 foam = vec3(0.93, 0.95, 0.97) * lit;
    float white = clamp((0.35 + 0.65 * air) * thick * (1.6 * s - 0.1), 0.0, 1.0);
    vec3 colour = mix(water * (0.6 + 0.6 * s), foam, white);
    float alpha = clamp(thick * (0.75 + 0.35 * air) + fresnel * edge, 0.0, 0.97);
    frag = vec4(apply_fog(colour, v_world), alpha);
}
#endif
