// The concentration mode's legend (issue 24, riverflow/systems/legend.py): a panel in the
// frame's corner, its colour bar from spill.glsl's concentration_ramp (the water's ramp), its
// ticks and labels from u_legend (RGBA8, the panel's size, row 0 at the bottom), blended
// over the frame; in front of everything (depth 0: a host compositing the frame keeps it).
uniform ivec4 u_legend_panel;   // (x0, y0, w, h) [px] in the frame, origin lower left
uniform ivec4 u_legend_bar;     // (x0, y0, w, h) [px] in the panel
uniform vec2 u_legend_frame;    // the frame's size [px]

#ifdef VERTEX
void main() {
    // two triangles over the panel
    int k = gl_VertexID % 6;
    vec2 corner = vec2((k == 1 || k == 2 || k == 4) ? 1.0 : 0.0,
                       (k == 2 || k == 4 || k == 5) ? 1.0 : 0.0);
    vec2 px = vec2(u_legend_panel.xy) + corner * vec2(u_legend_panel.zw);
    gl_Position = vec4(px / u_legend_frame * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT
#include "spill.glsl"
uniform sampler2D u_legend;
out vec4 frag;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy) - u_legend_panel.xy;
    ivec2 b = p - u_legend_bar.xy;
    if (all(greaterThanEqual(b, ivec2(0))) && all(lessThan(b, u_legend_bar.zw))) {
        frag = vec4(concentration_ramp((float(b.y) + 0.5) / float(u_legend_bar.w)), 1.0);
    } else {
        frag = texelFetch(u_legend, p, 0);
    }
    gl_FragDepth = 0.0;
}
#endif
