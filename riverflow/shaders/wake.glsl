// Kelvin wakes: the waves behind each boat, added to the water's slopes (riverflow.components.
// wake). A source moving at speed U through deep water leaves a steady pattern inside a wedge
// of half-angle asin(1/3) = 19.47 degrees behind it: at distance X behind and Y beside it,
// the waves of direction phi (tan phi = t) with 2 Y t^2 + X t + Y = 0 (stationary phase) have
// wavenumber k = (g / U^2)(1 + t^2) and phase (g / U^2)(X + Y t) sqrt(1 + t^2): a transverse
// wave (the root near 0, wavelength 2 pi U^2 / g on the track) and a diverging one (the other
// root, shorter). Real roots need |Y| <= X / sqrt(8): the wedge. For a boat that turns or
// drifts, X and Y are measured along and across its trail (where its bow was, drifted with
// the current): X is the distance along the trail from the bow, Y the signed distance from
// it, U the boat's speed through the water when it was there.
//
// The wake table (RGBA32F, 1 + 2 * TRAIL_POINTS texels x MAX_WAKES rows), boat b in row b:
// texel 0 the box (xmin, ymin, xmax, ymax) [m] outside which its wake is flat; texel 1 + j
// point j of its trail (x, y [m], distance along the trail from the bow [m], U [m/s]), arc
// < 0 past the last point; texel 1 + TRAIL_POINTS + j (strength 0..1, foam half-width [m],
// age [s], the wake's wave slope).
uniform sampler2D u_wakes;
uniform int u_wake_count;

const float WAKE_G = 9.81;
const float WAKE_CUSP = 0.35355339;      // tan(19.47 deg) = 1 / sqrt(8)
const float WAKE_TRANSVERSE = 0.55;      // transverse waves, relative to the diverging ones

// One family of waves: slope in the wake's (back, port) frame, faded where shorter than a
// few pixels (px_m: a pixel's size there [m]).
vec2 kelvin_wave(float t, float X, float Y, float k0, float px_m) {
    float c2 = 1.0 + t * t;
    float k = k0 * c2;
    float visible = clamp((6.2831853 / (k * max(px_m, 1e-4)) - 3.0) / 3.0, 0.0, 1.0);
    if (visible <= 0.0) return vec2(0.0);
    float phase = k0 * (X + Y * t) * sqrt(c2);
    return visible * sin(phase) * vec2(1.0, t) / sqrt(c2);
}

// d(height)/d(x, y) of every boat's Kelvin wake at world point p (px_m as above); crest: the
// foam of its breaking crests, where the wake is steeper than WAKE_BREAK (the cusp lines next
// to a fast boat).
const float WAKE_BREAK = 0.35;
vec2 wake_slopes(vec2 p, float px_m, out float crest) {
    vec2 total = vec2(0.0);
    crest = 0.0;
    for (int b = 0; b < u_wake_count; ++b) {
        vec4 box = texelFetch(u_wakes, ivec2(0, b), 0);
        if (p.x < box.x || p.y < box.y || p.x > box.z || p.y > box.w) continue;
        // the trail point nearest p: segment jb (points jb - 1, jb) at fraction sb
        vec4 a = texelFetch(u_wakes, ivec2(1, b), 0);
        float best = 1e30, sb = 0.0;
        int jb = 0, last = 0;
        vec2 back = vec2(0.0), dv = vec2(0.0);
        for (int j = 1; j < TRAIL_POINTS; ++j) {
            vec4 q = texelFetch(u_wakes, ivec2(1 + j, b), 0);
            if (q.z < 0.0) break;
            vec2 e = q.xy - a.xy;                       // from the newer point back
            float len2 = dot(e, e);
            if (len2 > 1e-8) {
                float s = clamp(dot(p - a.xy, e) / len2, 0.0, 1.0);
                vec2 d = p - (a.xy + s * e);
                float dist2 = dot(d, d);
                if (dist2 < best) {
                    best = dist2;
                    jb = j;
                    sb = s;
                    back = e * inversesqrt(len2);
                    dv = d;
                }
            }
            a = q;
            last = j;
        }
        if (jb == 0) continue;
        vec4 a1 = texelFetch(u_wakes, ivec2(jb, b), 0);
        vec4 q1 = texelFetch(u_wakes, ivec2(1 + jb, b), 0);
        vec4 a2 = texelFetch(u_wakes, ivec2(TRAIL_POINTS + jb, b), 0);
        vec4 q2 = texelFetch(u_wakes, ivec2(1 + TRAIL_POINTS + jb, b), 0);
        vec2 port = vec2(back.y, -back.x);              // left of the boat's motion (-back)
        float X = mix(a1.z, q1.z, sb);
        float Y = dot(dv, port);
        float U = mix(a1.w, q1.w, sb);
        float strength = mix(a2.x, q2.x, sb);
        if (strength <= 0.0 || U < 0.3 || X <= 0.0) continue;
        float r = abs(Y) / X;
        if (r > 1.06 * WAKE_CUSP) continue;
        float k0 = WAKE_G / (U * U);
        // past the trail's oldest point the wake fades out over half a wavelength (else the
        // distance to that point would draw rings around it)
        float past = jb == last && sb >= 1.0 ? max(dot(dv, back), 0.0) : 0.0;
        float amp = a2.w * strength * smoothstep(0.0, 4.0, X)
                  * (1.0 - smoothstep(0.0, 3.14159265 / k0, past))
                  * inversesqrt(1.0 + X * k0 / 6.2831853 * 0.5)
                  * (1.0 - smoothstep(0.88 * WAKE_CUSP, 1.06 * WAKE_CUSP, r));
        float rr = min(r, WAKE_CUSP);
        float D = sqrt(max(X * X - 8.0 * Y * Y, 0.0));
        float cusp = 1.0 + 0.8 * exp(-pow((WAKE_CUSP - rr) / (0.18 * WAKE_CUSP), 2.0));
        vec2 w = WAKE_TRANSVERSE * kelvin_wave(-2.0 * Y / (X + D), X, Y, k0, px_m);
        if (abs(Y) > 1e-3)
            w += smoothstep(0.0, 0.5 * WAKE_CUSP, r)
               * kelvin_wave(-(X + D) / (4.0 * Y), X, Y, k0, px_m);
        w *= amp * cusp;
        total += w.x * back + w.y * port;
        crest = max(crest, strength * smoothstep(WAKE_BREAK, 2.0 * WAKE_BREAK, length(w)));
    }
    return total;
}
