// The sprite table (RGBA32F, kernels/sprites.py): entry e at row e / PARTICLES_PER_ROW,
// texels TEXELS_PER_PARTICLE * (e % PARTICLES_PER_ROW) + 0..3:
//   0: screen x [px], screen y [px], world x [m], world y [m]
//   1: offset x [m], offset y [m], intensity, r [px]
//   2: flow status (-1: free entry), velocity x [m/s], velocity y [m/s], world z [m]
//   3: foam in [0, 1], 0, 0, 0
// The sprites drawn on the water come first (sorted by screen bin: sprite_bins.glsl), then the
// other particles when an overlay shows them.
uniform sampler2D u_params;

vec4 sprite_param(int entry, int texel) {
    ivec2 at = ivec2(TEXELS_PER_PARTICLE * (entry % PARTICLES_PER_ROW) + texel,
                     entry / PARTICLES_PER_ROW);
    return texelFetch(u_params, at, 0);
}

bool sprite_drawn(float status, float intensity) {
    int s = int(status);
    return (s == FLOW_STATUS_INSIDE || s == FLOW_STATUS_LEAVING) && intensity > 0.0;
}
