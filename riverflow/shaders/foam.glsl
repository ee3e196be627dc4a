// Foam on the water, carried by the particles (riverflow.kernels.foam): each particle's foam
// amount (texel 3 of its sprite entry, params.glsl) is blended through the same sprite
// weights as the wave slopes (water.glsl), and so is a lace pattern sampled in each sprite's
// own frame, so the foam's texture moves with the water. The pattern (RG, mipmapped,
// periodic): values spread evenly over [0, 1]; channel g slides slowly over channel r (the
// foam churns).
uniform sampler2D u_foam_pattern;
uniform float u_foam_scale_m;       // world size of one period of the pattern [m]
uniform float u_foam_size_px;       // texels of one period (level 0)
uniform float u_time_s;

const vec3 FOAM_ALBEDO = vec3(0.93, 0.96, 0.98);
const float FOAM_MIN = 0.02;        // a sprite with less foam samples no pattern

// The pattern at uv (pattern periods) with its screen derivatives.
float foam_lace(vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    float a = textureGrad(u_foam_pattern, uv, duv_dx, duv_dy).r;
    vec2 drift = vec2(0.013, -0.009) * u_time_s;
    float b = textureGrad(u_foam_pattern, 1.618 * uv + drift, 1.618 * duv_dx, 1.618 * duv_dy).g;
    return 0.62 * a + 0.38 * b;
}

// How much of the pixel foam covers: foam amount f in [0, 1] (the sprites' weighted mean),
// lace t (the sprites' patterns blended, contrast kept: 0.5 + sum w (p - 0.5) / sqrt(sum w^2))
// and duv_dx/dy the pattern's screen derivatives. Foam shows where the lace exceeds 1 - f;
// far away, where the pattern's mips have averaged it out, the edge softens so that the
// coverage tends to f itself.
float foam_cover(float f, float t, vec2 duv_dx, vec2 duv_dy) {
    if (f <= 0.0) return 0.0;
    float texels = max(length(duv_dx), length(duv_dy)) * u_foam_size_px;
    float far = clamp(log2(max(texels, 1.0)) / 5.0, 0.0, 1.0);
    float soft = mix(0.07, 0.55, far);
    float edge = 1.0 - f;
    return smoothstep(edge - soft, edge + soft, mix(t, 0.5, 0.6 * far)) * smoothstep(0.0, 0.08, f);
}

// The foam line along the waterline itself, per pixel (particles are metres apart): where
// the water is under SHORELINE_DEPTH_M deep, u_shoreline strong, more where the particles
// there carry foam (f: their blended amount).
uniform float u_shoreline;
uniform float u_crest_foam;         // 1: the wakes' breaking crests make foam (0: foam off)
const float SHORELINE_DEPTH_M = 1.2;
float shoreline_foam(float depth_m, float f) {
    return u_shoreline * (1.0 - smoothstep(0.0, SHORELINE_DEPTH_M, depth_m))
         * (0.55 + 0.45 * smoothstep(0.0, 0.35, f));
}

// Foam's colour lit by the sun and the sky, seen along unit normal n.
vec3 foam_colour(vec3 n) {
    float sun = max(dot(n, u_sun_dir), 0.0);
    vec3 sky = 0.5 * (sky_colour(vec3(0.0, 0.0, 1.0)) + sky_colour(normalize(vec3(n.xy, 0.3))));
    return FOAM_ALBEDO * (0.85 * SUN_COLOUR * sun + 0.6 * sky);
}
