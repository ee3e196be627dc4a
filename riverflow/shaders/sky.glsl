// Sky behind everything: one full-screen triangle, the radiance along each pixel's ray.
#include "common.glsl"

#ifdef VERTEX
out vec2 v_ndc;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    v_ndc = p;
    gl_Position = vec4(p, 1.0, 1.0);
}
#endif

#ifdef FRAGMENT
in vec2 v_ndc;
out vec4 frag;
void main() {
    vec4 far = u_world_from_clip * vec4(v_ndc, 1.0, 1.0);
    vec3 dir = normalize(far.xyz / far.w - u_eye_m);
    frag = vec4(sky_colour(dir), 1.0);
}
#endif
