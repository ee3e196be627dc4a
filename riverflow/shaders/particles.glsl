// Particles as round points of size r at their screen positions, coloured by flow status
// × intensity (Proland's colours; NEAR always full), drawn additively.
#include "common.glsl"
#include "params.glsl"

#ifdef VERTEX
out vec3 v_colour;
void main() {
    int slot = gl_VertexID;
    vec4 p0 = sprite_param(slot, 0);
    vec4 p1 = sprite_param(slot, 1);
    vec4 p2 = sprite_param(slot, 2);
    int s = int(p2.x);
    if (s < 0) { gl_Position = vec4(2.0, 2.0, 2.0, 1.0); gl_PointSize = 1.0; return; }
    vec3 c = vec3(0.0);
    if (s == FLOW_STATUS_INSIDE) c = vec3(0.0, 0.0, 1.0);
    else if (s == FLOW_STATUS_LEAVING) c = vec3(0.0, 1.0, 0.0);
    else if (s == FLOW_STATUS_NEAR) c = vec3(0.0, 0.5, 0.5);
    else if (s == FLOW_STATUS_OUTSIDE) c = vec3(1.0, 0.0, 0.0);
    else if (s == FLOW_STATUS_LEAVING_DOMAIN) c = vec3(0.5, 0.0, 0.5);
    else if (s == FLOW_STATUS_OUTSIDE_DOMAIN) c = vec3(1.0, 1.0, 0.0);
    else if (s == FLOW_STATUS_ON_SKY) c = vec3(1.0);
    v_colour = c * (s == FLOW_STATUS_NEAR ? 1.0 : p1.z);
    gl_PointSize = max(p1.w, 1.0);
    gl_Position = vec4(p0.xy / u_viewport_px * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT
in vec3 v_colour;
out vec4 frag;
void main() {
    if (length(gl_PointCoord - 0.5) > 0.5) discard;
    frag = vec4(v_colour, 1.0);
}
#endif
