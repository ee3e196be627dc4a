// The world's frame into a host's framebuffer (RiverWorld(gl="current")): each pixel of the
// world's colour target with its depth, depth-tested against what the host drew before (a
// host object in front of the water hides it; the water hides what is under it). The
// viewport is the host's, the same size as the world's targets: texels are copied, not
// filtered. Pixels nothing was drawn in (depth 1: the sky) are left to the host unless
// u_sky, then drawn at the far plane (behind everything the host drew).

#ifdef VERTEX
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT
uniform sampler2D u_colour;
uniform sampler2D u_depth;
uniform ivec2 u_origin_px;   // the host viewport's lower-left corner
uniform bool u_sky;
out vec4 frag;
void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy) - u_origin_px;
    float depth = texelFetch(u_depth, texel, 0).r;
    if (depth >= 1.0 && !u_sky) {
        discard;
    }
    frag = texelFetch(u_colour, texel, 0);
    gl_FragDepth = depth;
}
#endif
