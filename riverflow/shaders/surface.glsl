// The scene's heightfields as one RGBA32F texture on the terrain grid:
// r = ground [m], g = water level [m] (extended past the water to the nearest wet node),
// b = 1 on wet nodes, 0 on dry ones.
uniform sampler2D u_surface;
uniform vec4 u_surface_map;    // (origin x [m], origin y [m], 1 / cell [1/m], unused)

vec4 surface_at(vec2 xy_m) {
    vec2 size = vec2(textureSize(u_surface, 0));
    vec2 uv = ((xy_m - u_surface_map.xy) * u_surface_map.z + 0.5) / size;
    return texture(u_surface, uv);
}
