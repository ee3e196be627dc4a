// The land and the props mirrored in the water (issue 12 item 3), for the water shader.
//
// The draw system renders the terrain and the props mirrored in the plane z = u_mirror_level_m
// (the level of the visible water nearest the camera: riverflow.scenes.reflection) into
// u_reflection (premultiplied colour, alpha = something drawn; unfogged) and
// u_reflection_depth, in the frame's own screen space at a reduced resolution. What is under
// the water is clipped away there (terrain below its water level, props below their waterline).
// Nothing is drawn where the sky shows: the sky stays the exact sky_colour(r).
//
// A river's level falls along its course: water Δ above the mirror sees a point Q's image 2Δ
// higher than the texture has it, and the wave normal bends the ray away from the pixel. So
// the reflected ray is followed through the texture: mirrored into the texture's world it is
// o + t·rv (o = the water point moved by 2(L − z) vertically, rv = the ray mirrored), whose
// clip position s·C_o + C_d (s = 1/t, C_o = VP·(o, 1), C_d = VP·(rv, 0)) is linear in s. It is
// marched from near to far in even steps of s (even on screen) until it passes behind the
// texture's depth, then refined by bisection. Where the level matches and the water is flat,
// the segment is a point and one step finds the plain planar reflection.
uniform bool u_reflect;                // a reflection was drawn this frame
uniform sampler2D u_reflection;        // premultiplied RGB, alpha = covered (LINEAR)
uniform sampler2D u_reflection_depth;  // depth of the mirrored pass (NEAREST)
uniform float u_mirror_level_m;        // L [m]
uniform mat4 u_world_from_clip;        // the camera's clip → world
uniform float u_reflection_distortion; // 1: rays bent by the wave normal; 0: flat mirror

const int REFLECTION_MAX_STEPS = 16;   // march steps at most (about one per 2 texels)
const int REFLECTION_REFINE = 3;       // bisection steps after the march
const float REFLECTION_NEAR_M = 0.25;  // the march starts this far from the water
const float REFLECTION_MISS_TEXELS = 1.5;  // a ray passing farther from a surface misses it
const float REFLECTION_EDGE = 0.03;    // fade out over this share of the screen at its edges
const float REFLECTION_MAX_LOD = 4.0;  // blur rough water over at most 16 texels

vec2 clip_uv(vec4 c) {
    return c.xy / c.w * 0.5 + 0.5;
}

// True when the ray point at clip position c lies behind what the texture shows there.
bool behind(vec4 c) {
    vec2 uv = clip_uv(c);
    float stored = textureLod(u_reflection_depth, clamp(uv, 0.0, 1.0), 0.0).r * 2.0 - 1.0;
    return c.z / c.w >= stored;
}

// The point of the texture's world drawn at uv [m] (the far plane where nothing was drawn).
vec3 mirror_image(vec2 uv) {
    float d = textureLod(u_reflection_depth, clamp(uv, 0.0, 1.0), 0.0).r;
    vec4 w = u_world_from_clip * vec4(uv * 2.0 - 1.0, d * 2.0 - 1.0, 1.0);
    return w.xyz / w.w;
}

// The radiance reflected towards the eye by water point p (unit view vector v towards the
// eye, wave normal n): the reflected land and props over `sky` (the sky along the reflected
// ray), fogged over the reflected ray's length (the water shader fogs the rest). Call it in
// uniform control flow: the texture's level of detail comes from how far the reflected ray's
// direction moves between neighbouring pixels (rough water: the mip level then averages what
// the waves show, instead of one speckled sample per pixel).
vec3 reflected_scene(vec3 p, vec3 v, vec3 n, vec3 sky) {
    vec3 nd = normalize(vec3(n.xy * u_reflection_distortion, n.z));
    vec3 r = reflect(-v, nd);
    r.z = abs(r.z);            // bent down into the water: up again off the next wave (as the sky)
    vec3 rv = vec3(r.xy, -r.z);
    vec3 o = p + vec3(0.0, 0.0, 2.0 * (u_mirror_level_m - p.z));
    vec4 c_o = u_view_projection * vec4(o, 1.0);
    vec4 c_d = u_view_projection * vec4(rv, 0.0);
    vec2 dir_uv = c_d.xy / max(abs(c_d.w), 1e-4) * 0.5;
    vec2 texels = vec2(textureSize(u_reflection, 0));
    vec2 du = dFdx(dir_uv) * texels, dv = dFdy(dir_uv) * texels;
    float lod = clamp(0.5 * log2(max(max(dot(du, du), dot(dv, dv)), 1e-8)), 0.0,
                      REFLECTION_MAX_LOD);
    if (!u_reflect || u_eye_m.z <= p.z + 1e-3 || c_o.w <= 1e-4) return sky;  // from below

    // s from 1 / REFLECTION_NEAR_M down to 0 (the far end), but not behind the camera
    float s0 = 1.0 / REFLECTION_NEAR_M;
    float s1 = c_d.w > 1e-4 ? 0.0 : (1e-4 - c_d.w) / c_o.w;
    if (s1 >= s0) return sky;
    float span = length((clip_uv(s1 * c_o + c_d) - clip_uv(s0 * c_o + c_d)) * texels);
    int steps = int(clamp(ceil(0.5 * span), 1.0, float(REFLECTION_MAX_STEPS)));
    float s_in = s0;                    // the last step in front of the texture's surface
    float s_hit = -1.0;
    for (int k = 0; k <= steps && s_hit < 0.0; ++k) {
        float s = mix(s0, s1, float(k) / float(steps));
        vec4 c = s * c_o + c_d;
        vec2 uv = clip_uv(c);
        if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) break;
        if (!behind(c)) { s_in = s; continue; }
        float s_out = s;                // behind: bisect between s_in and here
        for (int j = 0; j < REFLECTION_REFINE && k > 0; ++j) {
            float m = 0.5 * (s_in + s_out);
            if (behind(m * c_o + c_d)) s_out = m; else s_in = m;
        }
        // a hit if the surface drawn there is on the ray (within REFLECTION_MISS_TEXELS);
        // else the ray only passed behind an edge (seen from the eye): march on
        vec2 uv_hit = clip_uv(s_out * c_o + c_d);
        vec3 x = mirror_image(uv_hit);
        vec4 c_near = u_view_projection * vec4(o + max(dot(x - o, rv), 0.0) * rv, 1.0);
        if (c_near.w > 1e-4
                && length((clip_uv(c_near) - uv_hit) * texels) < REFLECTION_MISS_TEXELS)
            s_hit = s_out;
        s_in = s;
    }
    if (s_hit < 0.0) return sky;
    vec2 uv = clip_uv(s_hit * c_o + c_d);
    vec2 edge = min(uv, 1.0 - uv) / REFLECTION_EDGE;
    float inside = clamp(min(edge.x, edge.y), 0.0, 1.0);
    vec4 c = textureLod(u_reflection, clamp(uv, 0.0, 1.0), lod) * inside;
    float fog = 1.0 - exp(-u_fog_density / max(s_hit, 1e-6));
    return sky * (1.0 - c.a) + mix(c.rgb, FOG_COLOUR * c.a, fog);
}
