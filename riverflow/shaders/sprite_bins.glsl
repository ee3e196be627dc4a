// The sprite bins (kernels/sprites.py): the sprite table's drawn entries sorted by screen bin,
// row-major; texel (bx, by) of u_bins (a buffer texture of bh rows of bw + 1, texel
// by * (bw + 1) + bx) is the first entry of bin (bx, by), texel (bw, by) the end of row by. The sprites that may meet a screen rectangle are found row by row: the bin
// rows within the sprite radius of it and, in each, one range of entries (the bins that the
// rectangle grown by the radius meets at that row's height).
uniform isamplerBuffer u_bins;      // R32I, (bw + 1) x bh
uniform ivec2 u_bin_px;             // bin width, height [px]
uniform ivec2 u_bin_margin;         // bins left of / below the screen
uniform ivec2 u_bin_count;          // bins (bw, bh), margins included
uniform float u_sprite_radius_px;   // 3r

// Slack of the look-ups [px]: float rounding near a bin edge never loses a sprite (one that
// is farther is only tested, not taken).
const float BIN_SLACK_PX = 0.5;

// Bin rows [x, y] that may hold the centre of a sprite meeting the rectangle [lo, hi] [px].
ivec2 bin_rows(vec2 lo, vec2 hi) {
    float reach = u_sprite_radius_px + BIN_SLACK_PX;
    float h = float(u_bin_px.y);
    int first = int(floor((lo.y - reach) / h)) + u_bin_margin.y;
    int last = int(floor((hi.y + reach) / h)) + u_bin_margin.y;
    return ivec2(max(first, 0), min(last, u_bin_count.y - 1));
}

// Entries [x, y) of the sprite table whose centres lie in the bins of row by that may hold a
// sprite meeting the rectangle [lo, hi].
ivec2 bin_range(vec2 lo, vec2 hi, int by) {
    float h = float(u_bin_px.y);
    float w = float(u_bin_px.x);
    float y0 = float(by - u_bin_margin.y) * h;
    float dy = max(max(y0 - hi.y, lo.y - (y0 + h)), 0.0);
    float reach = u_sprite_radius_px + BIN_SLACK_PX;
    float half_chord = sqrt(max(reach * reach - dy * dy, 0.0)) + BIN_SLACK_PX;
    int first = clamp(int(floor((lo.x - half_chord) / w)) + u_bin_margin.x, 0, u_bin_count.x - 1);
    int last = clamp(int(floor((hi.x + half_chord) / w)) + u_bin_margin.x, 0, u_bin_count.x - 1);
    int row = by * (u_bin_count.x + 1);
    return ivec2(texelFetch(u_bins, row + first).r, texelFetch(u_bins, row + last + 1).r);
}
