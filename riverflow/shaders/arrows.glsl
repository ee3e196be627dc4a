// Velocity arrows: per particle with a world position, a shaft from the particle along its
// flow velocity (u_arrow_s seconds of travel) and two head strokes, as 3 line segments.
#include "common.glsl"
#include "params.glsl"
uniform float u_arrow_s;

#ifdef VERTEX
out vec4 v_colour;

vec2 to_px(vec3 world) {
    vec4 c = u_view_projection * vec4(world, 1.0);
    return (c.xy / max(c.w, 1e-6) * 0.5 + 0.5) * u_viewport_px;
}

void main() {
    int slot = gl_VertexID / 6;
    int corner = gl_VertexID % 6;
    vec4 p0 = sprite_param(slot, 0);
    vec4 p1 = sprite_param(slot, 1);
    vec4 p2 = sprite_param(slot, 2);
    if (!sprite_drawn(p2.x, p1.z)) { gl_Position = vec4(2.0, 2.0, 2.0, 1.0); return; }
    vec3 base = vec3(p0.zw, p2.w);
    vec2 a = p0.xy;                                   // the particle's own screen position
    vec2 b = to_px(base + vec3(p2.yz * u_arrow_s, 0.0));
    vec2 d = b - a;
    float len = length(d);
    vec2 u = len > 1e-3 ? d / len : vec2(1.0, 0.0);
    float head = min(0.35 * len, 6.0);
    vec2 left = b - head * (0.9 * u + 0.45 * vec2(-u.y, u.x));
    vec2 right = b - head * (0.9 * u - 0.45 * vec2(-u.y, u.x));
    vec2 ends[6] = vec2[6](a, b, b, left, b, right);
    float speed = length(p2.yz);
    v_colour = vec4(mix(vec3(1.0, 1.0, 0.3), vec3(1.0, 0.25, 0.1), clamp(speed / 2.0, 0.0, 1.0)),
                    p1.z);
    gl_Position = vec4(ends[corner] / u_viewport_px * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT
in vec4 v_colour;
out vec4 frag;
void main() {
    frag = v_colour;
}
#endif
