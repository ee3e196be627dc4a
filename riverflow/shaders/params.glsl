// The sprite table (RGBA32F, kernels/sprites.py), a buffer texture: entry e at texels
// TEXELS_PER_PARTICLE * e + 0..3 (the kernel's rows of PARTICLES_PER_ROW entries, end to end):
//   0: screen x [px], screen y [px], world x [m], world y [m]
//   1: offset x [m], offset y [m], intensity, r [px]
//   2: flow status (-1: free entry), velocity x [m/s], velocity y [m/s], world z [m]
//   3: foam in [0, 1], spill concentration c [kg/m3], spill colour (packed: spill.glsl), 0
// The sprites drawn on the water come first (sorted by screen bin: sprite_bins.glsl), then the
// other particles when an overlay shows them.
uniform samplerBuffer u_params;

vec4 sprite_param(int entry, int texel) {
    return texelFetch(u_params, TEXELS_PER_PARTICLE * entry + texel);
}

bool sprite_drawn(float status, float intensity) {
    int s = int(status);
    return (s == FLOW_STATUS_INSIDE || s == FLOW_STATUS_LEAVING) && intensity > 0.0;
}
