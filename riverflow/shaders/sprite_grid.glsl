// The sprite grid (kernels/sprites.py): which entries of the sprite table may cover a pixel.
// The table's drawn entries are sorted by screen cell, row-major; texel (cx, cy) of u_grid is
// the first entry of cell (cx, cy), texel (gw, cy) the end of row cy. A pixel visits the cell
// rows within the sprite radius of it and, in each, one range of entries: the cells that the
// disc's chord at that row meets.
uniform isampler2D u_grid;          // R32I, (gw + 1) x gh
uniform ivec2 u_grid_cell_px;       // cell width, height [px]
uniform ivec2 u_grid_margin;        // cells left of / below the screen
uniform ivec2 u_grid_size;          // cells (gw, gh), margins included
uniform float u_sprite_radius_px;   // 3r

// Slack of the look-ups [px]: float rounding near a cell edge never loses a sprite (one
// that is farther is only tested, not drawn).
const float GRID_SLACK_PX = 0.5;

// Cell rows [x, y] that may hold the centre of a sprite covering pixel centre st.
ivec2 sprite_rows(vec2 st) {
    float reach = u_sprite_radius_px + GRID_SLACK_PX;
    float h = float(u_grid_cell_px.y);
    int lo = int(floor((st.y - reach) / h)) + u_grid_margin.y;
    int hi = int(floor((st.y + reach) / h)) + u_grid_margin.y;
    return ivec2(max(lo, 0), min(hi, u_grid_size.y - 1));
}

// Entries [x, y) of the sprite table whose centres lie in the cells of row cy that a disc of
// the sprite radius around st meets.
ivec2 sprite_range(vec2 st, int cy) {
    float h = float(u_grid_cell_px.y);
    float w = float(u_grid_cell_px.x);
    float y0 = float(cy - u_grid_margin.y) * h;
    float dy = max(max(y0 - st.y, st.y - (y0 + h)), 0.0);
    float reach = u_sprite_radius_px + GRID_SLACK_PX;
    float half_chord = sqrt(max(reach * reach - dy * dy, 0.0)) + GRID_SLACK_PX;
    int lo = clamp(int(floor((st.x - half_chord) / w)) + u_grid_margin.x, 0, u_grid_size.x - 1);
    int hi = clamp(int(floor((st.x + half_chord) / w)) + u_grid_margin.x, 0, u_grid_size.x - 1);
    return ivec2(texelFetch(u_grid, ivec2(lo, cy), 0).r, texelFetch(u_grid, ivec2(hi + 1, cy), 0).r);
}
