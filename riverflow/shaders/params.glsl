// The sprite parameter table (RGBA32F): particle slot i at row i / PARTICLES_PER_ROW,
// texels TEXELS_PER_PARTICLE * (i % PARTICLES_PER_ROW) + 0..2:
//   0: screen x [px], screen y [px], world x [m], world y [m]
//   1: offset x [m], offset y [m], intensity, r [px]
//   2: flow status (-1: free slot), velocity x [m/s], velocity y [m/s], world z [m]
uniform sampler2D u_params;

vec4 sprite_param(int slot, int texel) {
    ivec2 at = ivec2(TEXELS_PER_PARTICLE * (slot % PARTICLES_PER_ROW) + texel,
                     slot / PARTICLES_PER_ROW);
    return texelFetch(u_params, at, 0);
}

bool sprite_drawn(float status, float intensity) {
    int s = int(status);
    return (s == FLOW_STATUS_INSIDE || s == FLOW_STATUS_LEAVING) && intensity > 0.0;
}
