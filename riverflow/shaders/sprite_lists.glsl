// The sprite grid, made on the GPU: one fragment per grid cell (cells of u_cell_px, the
// viewport gw x gh) gathers from the sprite bins the entries whose sprite disc meets the cell
// and writes up to MAX_PER_CELL of them into four RGBA32I layers, -1 after the last. A cell
// that more sprites meet keeps the brightest (a full list swaps its first dimmest entry for a
// strictly brighter one, as Proland's CPU grid did).
#include "params.glsl"
#include "sprite_bins.glsl"
uniform int u_cell_px;

#ifdef VERTEX
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT
layout(location = 0) out ivec4 list0;
layout(location = 1) out ivec4 list1;
layout(location = 2) out ivec4 list2;
layout(location = 3) out ivec4 list3;

// Entry k of a 16-entry list held in four vectors is component k % 4 of vector k / 4; lists
// are written with compares, not indexed, so that no lane scatters to memory.
void main() {
    ivec4 ids[4] = ivec4[4](ivec4(NO_PARTICLE), ivec4(NO_PARTICLE), ivec4(NO_PARTICLE),
                            ivec4(NO_PARTICLE));
    vec4 levels[4] = vec4[4](vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));
    const ivec4 LANE = ivec4(0, 1, 2, 3);
    int count = 0;
    vec2 lo = floor(gl_FragCoord.xy) * float(u_cell_px);      // the cell [lo, hi)
    vec2 hi = lo + float(u_cell_px);
    float r2 = u_sprite_radius_px * u_sprite_radius_px;
    ivec2 rows = bin_rows(lo, hi);
    for (int by = rows.x; by <= rows.y; ++by) {
        ivec2 range = bin_range(lo, hi, by);
        for (int id = range.x; id < range.y; ++id) {
            vec4 p0 = sprite_param(id, 0);
            vec2 d = max(max(lo - p0.xy, p0.xy - hi), 0.0);    // disc-rectangle distance
            if (dot(d, d) > r2) continue;                      // the disc misses the cell
            float level = sprite_param(id, 1).z;
            int at = count;                                    // append, or when full (rare)
            if (count == MAX_PER_CELL) {                       // swap the first dimmest for a
                float least = levels[0].x;                     // strictly brighter one
                at = 0;
                for (int k = 1; k < MAX_PER_CELL; ++k) {
                    float l = levels[k / 4][k % 4];
                    if (l < least) { least = l; at = k; }
                }
                if (!(level > least)) continue;
            } else {
                ++count;
            }
            for (int v = 0; v < 4; ++v) {
                bvec4 here = equal(ivec4(at - 4 * v), LANE);
                ids[v] += (id - ids[v]) * ivec4(here);
                levels[v] = mix(levels[v], vec4(level), here);
            }
        }
    }
    list0 = ids[0];
    list1 = ids[1];
    list2 = ids[2];
    list3 = ids[3];
}
#endif
