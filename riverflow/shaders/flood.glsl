// Floods (issue 25): the water surface raised by the flood's level rise (the rating curve,
// riverflow.hydro.flood.FloodRouter). u_flood_cells: an R32F texture over the square
// u_flood_rect = (x0, y0, side) [m], each texel the flood-cell coordinate c + w of its centre
// (-1: none); u_flood_rise: R32F, each cell's rise [m], row major (rows of its width).
// u_flood_on = 0: no flood (nothing sampled).
uniform sampler2D u_flood_cells;
uniform sampler2D u_flood_rise;
uniform vec3 u_flood_rect;
uniform int u_flood_on;

float flood_cell_rise(int c) {
    int w = textureSize(u_flood_rise, 0).x;
    return texelFetch(u_flood_rise, ivec2(c % w, c / w), 0).r;
}

// The level's rise [m] at a world point (0 off the flood's square or its cells).
float flood_rise(vec2 xy) {
    if (u_flood_on == 0) return 0.0;
    vec2 uv = (xy - u_flood_rect.xy) / u_flood_rect.z;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) return 0.0;
    ivec2 size = textureSize(u_flood_cells, 0);
    float p = texelFetch(u_flood_cells, ivec2(uv * vec2(size)), 0).r;
    if (p < 0.0) return 0.0;
    int c = int(p);
    float w = p - float(c);
    return mix(flood_cell_rise(c), flood_cell_rise(c + 1), w);
}
