// Rapids: standing waves anchored to the bed where the water surface is steep (riverflow.
// hydro.falls: a rapid's surface slopes down it). Water running fast down a steep reach
// holds waves still against the flow (their phase speed equals the current's): crests across
// the downhill direction, RAPIDS_WAVELENGTH_M apart, bent and broken across the river by a
// slow variation, fixed in the world (they do not move while the sprites' texture flows
// through them) and steady in time. Their slope grows from 0 at a surface slope of
// u_rapids.y to u_rapids.x at u_rapids.z, and they fade out again on a fall's nappe (steeper
// than 1 : 3), where the water does not run along its bed; their steepest crests foam.
uniform vec3 u_rapids;                  // (wave slope at full rapids, slope from, slope full)

const float RAPIDS_WAVELENGTH_M = 3.0;
const float RAPIDS_NAPPE_FROM = 0.33;
const float RAPIDS_NAPPE_FULL = 0.5;

// d(height)/d(x, y) of the standing waves at world point p on a surface whose level has the
// gradient grad [m/m] (px_m: a pixel's size there [m]); crest: their foam, 0..1.
vec2 standing_slopes(vec2 p, vec2 grad, float px_m, out float crest) {
    crest = 0.0;
    float s = length(grad);
    float amount = smoothstep(u_rapids.y, u_rapids.z, s)
                 * (1.0 - smoothstep(RAPIDS_NAPPE_FROM, RAPIDS_NAPPE_FULL, s));
    float visible = clamp((RAPIDS_WAVELENGTH_M / max(px_m, 1e-4) - 3.0) / 3.0, 0.0, 1.0);
    if (amount <= 0.0 || visible <= 0.0 || u_rapids.x <= 0.0) return vec2(0.0);
    vec2 d = -grad / s;                                    // downhill
    vec2 across = vec2(-d.y, d.x);
    float k = 6.2831853 / RAPIDS_WAVELENGTH_M;
    float a = dot(p, d), c = dot(p, across);
    float phase = k * a + 1.7 * sin(0.37 * k * c) + 0.9 * sin(0.23 * k * c + 1.3);
    float envelope = 0.65 + 0.35 * sin(0.29 * k * c + 0.6 * sin(0.11 * k * a));
    float w = sin(phase);
    crest = amount * envelope * smoothstep(0.75, 0.98, w);
    return (visible * amount * envelope * u_rapids.x * cos(phase)) * d;
}
