// Benchmark only (benchmarks/bench_reflections.py): the GPU work of screen-space reflections
// on a drawn frame, for comparison with the planar pass. Every water pixel marches its
// reflected ray (flat water) through a copy of the frame's depth, at full resolution, with
// the march of riverflow/shaders/reflection.glsl (even steps on screen, bisection, hit
// validation; no early out: the frame has no sky-only mip chain), and blends the colour found.
#include "common.glsl"
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
const int MAX_STEPS = 24;           // the planar march's 12 at half resolution
const float STRIDE = 6.0;           // pixels: the planar march's 3 texels at half resolution
const int REFINE = 3;

bool behind(vec3 ndc) {
    float stored = textureLod(u_depth, clamp(ndc.xy * 0.5 + 0.5, 0.0, 1.0), 0.0).r * 2.0 - 1.0;
    return ndc.z >= stored;
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
    frag = vec4(0.0);
    if (c_d.w <= 1e-4) return;
    vec3 ndc_o = c_o.xyz / c_o.w, ndc_d = c_d.xyz / c_d.w;
    float l0 = 0.25 * c_d.w / (c_o.w + 0.25 * c_d.w);
    vec3 a = mix(ndc_o, ndc_d, l0);
    float span = length((ndc_d.xy - a.xy) * 0.5 * texels);
    int steps = int(clamp(ceil(span / STRIDE), 1.0, float(MAX_STEPS)));
    float f_in = 0.0;
    for (int k = 0; k <= steps; ++k) {
        float f = float(k) / float(steps);
        vec3 c = mix(a, ndc_d, f);
        if (any(greaterThan(abs(c.xy), vec2(1.0)))) break;
        if (!behind(c)) { f_in = f; continue; }
        float f_out = f;
        for (int j = 0; j < REFINE && k > 0; ++j) {
            float m = 0.5 * (f_in + f_out);
            if (behind(mix(a, ndc_d, m))) f_out = m; else f_in = m;
        }
        vec2 uv_hit = mix(a, ndc_d, f_out).xy * 0.5 + 0.5;
        vec3 x = image(uv_hit);
        vec4 c_near = u_view_projection * vec4(p + max(dot(x - p, r), 0.0) * r, 1.0);
        if (c_near.w > 1e-4
                && length((c_near.xy / c_near.w * 0.5 + 0.5 - uv_hit) * texels) < 1.5) {
            frag = vec4(textureLod(u_colour, uv_hit, 0.0).rgb, 0.5);
            break;
        }
        f_in = f;
    }
}
#endif
