// Benchmark only (benchmarks/bench_reflections.py): the GPU work of screen-space reflections
// on a drawn frame, for comparison with the planar pass. Every water pixel marches its
// reflected ray (flat water) through a copy of the frame's depth, at full resolution, with
// the march of riverflow/shaders/reflection.glsl (even steps of 1/t, about one per 2 pixels,
// bisection, hit validation), and blends the copied colour it finds.
#include "common.glsl"
uniform mat4 u_view_projection;
uniform mat4 u_world_from_clip;
uniform sampler2D u_colour;
uniform sampler2D u_depth;

#ifdef VERTEX
layout(location = 0) in vec3 a_position;
layout(location = 1) in float a_ground;
out vec3 v_world;
void main() {
    v_world = a_position + 0.0 * a_ground;
    gl_Position = u_view_projection * vec4(a_position, 1.0);
}
#endif

#ifdef FRAGMENT
in vec3 v_world;
out vec4 frag;
const int MAX_STEPS = 32;           // the planar march's 16 at half resolution
const int REFINE = 3;

vec2 clip_uv(vec4 c) { return c.xy / c.w * 0.5 + 0.5; }

bool behind(vec4 c) {
    float stored = textureLod(u_depth, clamp(clip_uv(c), 0.0, 1.0), 0.0).r * 2.0 - 1.0;
    return c.z / c.w >= stored;
}

vec3 image(vec2 uv) {
    float d = textureLod(u_depth, clamp(uv, 0.0, 1.0), 0.0).r;
    vec4 w = u_world_from_clip * vec4(uv * 2.0 - 1.0, d * 2.0 - 1.0, 1.0);
    return w.xyz / w.w;
}

void main() {
    vec3 p = v_world;
    vec3 v = normalize(u_eye_m - p);
    vec3 r = reflect(-v, vec3(0.0, 0.0, 1.0));
    vec4 c_o = u_view_projection * vec4(p, 1.0);
    vec4 c_d = u_view_projection * vec4(r, 0.0);
    vec2 texels = vec2(textureSize(u_depth, 0));
    float s0 = 1.0 / 0.25;
    float s1 = c_d.w > 1e-4 ? 0.0 : (1e-4 - c_d.w) / c_o.w;
    vec4 found = vec4(0.0);
    if (s1 < s0) {
        float span = length((clip_uv(s1 * c_o + c_d) - clip_uv(s0 * c_o + c_d)) * texels);
        int steps = int(clamp(ceil(0.5 * span), 1.0, float(MAX_STEPS)));
        float s_in = s0;
        for (int k = 0; k <= steps; ++k) {
            float s = mix(s0, s1, float(k) / float(steps));
            vec4 c = s * c_o + c_d;
            vec2 uv = clip_uv(c);
            if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) break;
            if (!behind(c)) { s_in = s; continue; }
            float s_out = s;
            for (int j = 0; j < REFINE && k > 0; ++j) {
                float m = 0.5 * (s_in + s_out);
                if (behind(m * c_o + c_d)) s_out = m; else s_in = m;
            }
            vec2 uv_hit = clip_uv(s_out * c_o + c_d);
            vec3 x = image(uv_hit);
            vec4 c_near = u_view_projection * vec4(p + max(dot(x - p, r), 0.0) * r, 1.0);
            if (c_near.w > 1e-4 && length((clip_uv(c_near) - uv_hit) * texels) < 1.5) {
                found = vec4(textureLod(u_colour, uv_hit, 0.0).rgb, 0.5);
                break;
            }
            s_in = s;
        }
    }
    frag = found;
}
#endif
