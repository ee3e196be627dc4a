// Rain ripples on the water: expanding, fading rings around recent drop hits, added to the
// water's slopes. The ripple table (RGBA32F, RIPPLE_RING × 1): x, y [m], water level [m],
// age [s] (age ≥ u_ripple_life_s or < 0: none). u_ripple_count = 0 (no rain) adds nothing.
uniform sampler2D u_ripples;
uniform int u_ripple_count;
uniform float u_ripple_life_s;

const float RIPPLE_SPEED_MPS = 0.6;      // ring radius growth (exaggerated: seen from afar)
const float RIPPLE_WAVELENGTH_M = 0.3;
const float RIPPLE_WIDTH_M = 0.22;       // Gaussian half-width of the ring's wave packet
const float RIPPLE_SLOPE = 0.6;
const float RIPPLE_FAR_PX_M = 0.25;          // peak slope of a fresh ring

// d(height)/d(x, y) of the rings at world point p; px_m: a pixel's size there [m] (rings
// finer than three pixels are drawn broader instead of aliasing; where a pixel is over
// RIPPLE_FAR_PX_M the rings fade out: sub-pixel there).
vec2 ripple_slopes(vec2 p, float px_m) {
    vec2 s = vec2(0.0);
    float visible = clamp(2.0 - px_m / RIPPLE_FAR_PX_M, 0.0, 1.0);
    if (visible <= 0.0) return s;
    float wavelength = max(RIPPLE_WAVELENGTH_M, 3.0 * px_m);
    float width = max(RIPPLE_WIDTH_M, 0.75 * wavelength);
    float k = 6.2831853 / wavelength;
    for (int i = 0; i < u_ripple_count; ++i) {
        vec4 r = texelFetch(u_ripples, ivec2(i, 0), 0);
        float age = r.w;
        if (age < 0.0 || age >= u_ripple_life_s) continue;
        vec2 d = p - r.xy;
        float dist = length(d);
        float radius = 0.05 + RIPPLE_SPEED_MPS * age;
        float e = dist - radius;
        if (abs(e) > 3.0 * width || dist < 1e-4) continue;
        float fade = 1.0 - age / u_ripple_life_s;
        float a = RIPPLE_SLOPE * fade * fade / k;
        float g = exp(-(e * e) / (width * width));
        float dh = a * g * (-k * sin(k * e) - 2.0 * e / (width * width) * cos(k * e));
        s += dh * d / dist;
    }
    return s * visible;
}
