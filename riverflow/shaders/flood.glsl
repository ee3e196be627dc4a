// Floods (issue 25): the water raised by the flood's level rise (the rating curve,
// riverflow.hydro.flood.FloodRouter), and the ground beside the river flooded where the
// raised level is above it. u_flood_cells: an RGB32F texture over the square
// u_flood_rect = (x0, y0, side) [m], each texel the flood-cell coordinate c + w of its centre
// (-1: none; within FLOODPLAIN_REACH_M of a centre line), the nearest other link's (-1: none)
// and the weight of that one's rise (up to 1/2 where both are equally near: the rise blends
// across the line where the nearest link changes, FLOOD_BLEND_M wide);
// u_flood_rise: RG32F per cell, row
// major (rows of its width): R the level's rise [m], G the rise up to which the ground
// looks wet (it lags behind a falling level). u_flood_on = 0: no flood (nothing sampled).
uniform sampler2D u_flood_cells;
uniform sampler2D u_flood_rise;
uniform vec3 u_flood_rect;
uniform int u_flood_on;

vec2 flood_cell(int c) {
    int w = textureSize(u_flood_rise, 0).x;
    return texelFetch(u_flood_rise, ivec2(c % w, c / w), 0).rg;
}

// (rise, wet rise) [m] at a cell coordinate c + w (between cell c's centre and c + 1's).
vec2 flood_coordinate(float p) {
    int c = int(p);
    return mix(flood_cell(c), flood_cell(c + 1), p - float(c));
}

// (rise, wet rise) [m] at a world point ((0, 0) off the flood's square or its cells).
vec2 flood_at(vec2 xy) {
    if (u_flood_on == 0) return vec2(0.0);
    vec2 uv = (xy - u_flood_rect.xy) / u_flood_rect.z;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) return vec2(0.0);
    ivec2 size = textureSize(u_flood_cells, 0);
    vec3 p = texelFetch(u_flood_cells, ivec2(uv * vec2(size)), 0).rgb;
    if (p.x < 0.0) return vec2(0.0);
    vec2 rise = flood_coordinate(p.x);
    return p.y < 0.0 ? rise : mix(rise, flood_coordinate(p.y), p.z);
}

// The level's rise [m] at a world point.
float flood_rise(vec2 xy) {
    return flood_at(xy).x;
}
