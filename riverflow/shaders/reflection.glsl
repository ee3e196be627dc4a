// The land and the props mirrored in the water (issue 12 item 3), for the water shader.
//
// The draw system renders the terrain and the props mirrored in the plane z = u_mirror_level_m
// (the level of the water in view, eased in time: riverflow.scenes.reflection) into
// u_reflection (premultiplied colour, alpha = something drawn; unfogged) and
// u_reflection_depth, in the frame's own screen space at a reduced resolution. What is under
// the water is clipped away there (terrain below its water level, props below their waterline).
// Nothing is drawn where the sky shows: the sky stays the exact sky_colour(r).
//
// A river's level falls along its course: water Δ above the mirror sees a point Q's image 2Δ
// higher than the texture has it, and the wave normal bends the ray away from the pixel. So
// the reflected ray is followed through the texture: mirrored into the texture's world it is
// o + t·rv (o = the water point moved by 2(L − z) vertically, rv = the ray mirrored). Its
// normalised device coordinates are mix(ndc(o), ndc(rv at infinity), λ) with
// λ = t·C_d.w / (C_o.w + t·C_d.w) (C_o = VP·(o, 1), C_d = VP·(rv, 0)): a straight segment on
// screen, depth included. It is marched in even steps along it (about one per
// REFLECTION_STRIDE texels) until it passes behind the texture's depth, refined by bisection,
// and the hit is kept if the surface drawn there lies on the ray (else the ray only passed
// behind an edge, seen from the eye, and the march goes on). Where the level matches and the
// water is flat the segment is a point, and one step finds the plain planar reflection.
//
// The mirror's level is held while the level of the water in view changes by less than
// MIRROR_HOLD_M (riverflow.scenes.reflection.hold_levels); beyond that a second pass at the
// new level (u_reflection_b, u_mirror_level_b_m) is cross-faded in (u_reflection_fade), each
// pass at a fixed level: far water at another level than the mirror reflects an erratic
// function of that level (its ray spans a few texels), so a mirror moving every frame made
// it flicker (issue 29 item 2).
uniform bool u_reflect;                // a reflection was drawn this frame
uniform sampler2D u_reflection;        // premultiplied RGB, alpha = covered (LINEAR, mips)
uniform sampler2D u_reflection_depth;  // depth of the mirrored pass (NEAREST)
uniform float u_mirror_level_m;        // L [m]
uniform sampler2D u_reflection_b;      // the same, mirrored at u_mirror_level_b_m
uniform sampler2D u_reflection_depth_b;
uniform float u_mirror_level_b_m;
uniform float u_reflection_fade;       // 0: the first pass alone; else its weight is 1 − this
uniform float u_reflection_distortion; // 1: rays bent by the wave normal; 0: flat mirror

const int REFLECTION_MAX_STEPS = 12;   // march steps at most
const float REFLECTION_STRIDE = 3.0;   // texels between steps (fewer when the segment is long)
const int REFLECTION_REFINE = 3;       // bisection steps after the march
const float REFLECTION_NEAR_M = 0.25;  // the march starts this far from the water
const float REFLECTION_MISS_TEXELS = 1.5;  // a ray passing farther from a surface misses it
const float REFLECTION_FAINT = 0.05;  // Fresnel weight under which the land fades out
const float REFLECTION_EDGE = 0.03;    // fade out over this share of the screen at its edges
const float REFLECTION_MAX_LOD = 4.0;  // blur rough water over at most 16 texels

// True when the ray point at normalised device coordinates ndc lies behind what the
// texture shows there.
bool behind(sampler2D depth, vec3 ndc) {
    float stored = textureLod(depth, clamp(ndc.xy * 0.5 + 0.5, 0.0, 1.0),
                              0.0).r * 2.0 - 1.0;
    return ndc.z >= stored;
}

// The point of the texture's world drawn at uv [m] (the far plane where nothing was drawn).
vec3 mirror_image(sampler2D depth, vec2 uv) {
    float d = textureLod(depth, clamp(uv, 0.0, 1.0), 0.0).r;
    vec4 w = u_world_from_clip * vec4(uv * 2.0 - 1.0, d * 2.0 - 1.0, 1.0);
    return w.xyz / w.w;
}

// The radiance reflected towards the eye by water point p (unit view vector v towards the
// eye, wave normal n): the reflected land and props over `sky` (the sky along the reflected
// ray), fogged over the reflected ray's length (the water shader fogs the rest). `weight` is
// the Fresnel factor the caller applies: under REFLECTION_FAINT (water seen from well above)
// the land would change the pixel by a level or two of 255 and is not looked for. Call it in
// uniform control flow: the texture's level of detail comes from how far the reflected ray's
// direction moves between neighbouring pixels (rough water: the mip level then averages what
// the waves show, instead of one speckled sample per pixel).
vec3 reflected_in(sampler2D colour, sampler2D depth, float level, vec3 p, vec3 v, vec3 n,
                  vec3 sky, float weight) {
    vec3 nd = normalize(vec3(n.xy * u_reflection_distortion, n.z));
    vec3 r = reflect(-v, nd);
    r.z = abs(r.z);            // bent down into the water: up again off the next wave (as the sky)
    vec3 rv = vec3(r.xy, -r.z);
    vec3 o = p + vec3(0.0, 0.0, 2.0 * (level - p.z));
    vec4 c_o = u_view_projection * vec4(o, 1.0);
    vec4 c_d = u_view_projection * vec4(rv, 0.0);
    vec3 ndc_d = c_d.xyz / max(abs(c_d.w), 1e-4);
    vec2 texels = vec2(textureSize(colour, 0));
    vec2 du = dFdx(ndc_d.xy) * 0.5 * texels, dv = dFdy(ndc_d.xy) * 0.5 * texels;
    float lod = clamp(0.5 * log2(max(max(dot(du, du), dot(dv, dv)), 1e-8)), 0.0,
                      REFLECTION_MAX_LOD);
    // none seen from under the surface, nor along a ray turning back towards the camera
    // (nothing the mirrored view holds: looking straight down, the sky above the camera)
    float shown = smoothstep(0.5 * REFLECTION_FAINT, REFLECTION_FAINT, weight);
    if (shown <= 0.0 || u_eye_m.z <= p.z + 1e-3 || c_o.w <= 1e-4 || c_d.w <= 1e-4) return sky;

    vec3 ndc_o = c_o.xyz / c_o.w;
    float t0 = REFLECTION_NEAR_M;
    float l0 = t0 * c_d.w / (c_o.w + t0 * c_d.w);
    vec3 a = mix(ndc_o, ndc_d, l0);                  // the segment a → ndc_d (t = ∞)
    float span = length((ndc_d.xy - a.xy) * 0.5 * texels);
    // nothing drawn anywhere near the segment (a mip level whose texels span it): the sky
    float around = textureLod(colour, (a.xy + ndc_d.xy) * 0.25 + 0.5,
                              log2(max(span, 1.0)) + 1.0).a;
    if (around <= 0.0) return sky;
    int steps = int(clamp(ceil(span / REFLECTION_STRIDE), 1.0, float(REFLECTION_MAX_STEPS)));
    float f_in = 0.0;                  // along the segment: the last step in front
    float f_hit = -1.0;
    for (int k = 0; k <= steps && f_hit < 0.0; ++k) {
        float f = float(k) / float(steps);
        vec3 c = mix(a, ndc_d, f);
        if (any(greaterThan(abs(c.xy), vec2(1.0)))) break;   // off the texture
        if (!behind(depth, c)) { f_in = f; continue; }
        float f_out = f;               // behind: bisect between f_in and here
        for (int j = 0; j < REFLECTION_REFINE && k > 0; ++j) {
            float m = 0.5 * (f_in + f_out);
            if (behind(depth, mix(a, ndc_d, m))) f_out = m; else f_in = m;
        }
        // a hit if the surface drawn there is on the ray (within REFLECTION_MISS_TEXELS);
        // else the ray only passed behind an edge (seen from the eye): march on
        vec2 uv_hit = mix(a, ndc_d, f_out).xy * 0.5 + 0.5;
        vec3 x = mirror_image(depth, uv_hit);
        vec4 c_near = u_view_projection * vec4(o + max(dot(x - o, rv), 0.0) * rv, 1.0);
        if (c_near.w > 1e-4 && length((c_near.xy / c_near.w * 0.5 + 0.5 - uv_hit) * texels)
                < REFLECTION_MISS_TEXELS)
            f_hit = f_out;
        f_in = f;
    }
    if (f_hit < 0.0) return sky;
    float l = mix(l0, 1.0, f_hit);
    float t = l >= 1.0 ? 1e9 : l * c_o.w / ((1.0 - l) * c_d.w);   // the hit's distance [m]
    vec2 uv = mix(a, ndc_d, f_hit).xy * 0.5 + 0.5;
    vec2 edge = min(uv, 1.0 - uv) / REFLECTION_EDGE;
    float inside = clamp(min(edge.x, edge.y), 0.0, 1.0);
    vec4 c = textureLod(colour, clamp(uv, 0.0, 1.0), lod) * (inside * shown);
    float fog = 1.0 - exp(-t * u_fog_density);
    return sky * (1.0 - c.a) + mix(c.rgb, FOG_COLOUR * c.a, fog);
}

// reflected_in through the held mirror's pass, cross-faded with the second pass while one
// is faded in (u_reflection_fade, a uniform: both calls in uniform control flow).
vec3 reflected_scene(vec3 p, vec3 v, vec3 n, vec3 sky, float weight) {
    if (!u_reflect) return sky;        // a uniform: the derivatives stay in uniform flow
    vec3 held = reflected_in(u_reflection, u_reflection_depth, u_mirror_level_m, p, v, n, sky,
                             weight);
    if (u_reflection_fade <= 0.0) return held;
    return mix(held, reflected_in(u_reflection_b, u_reflection_depth_b, u_mirror_level_b_m, p,
                                  v, n, sky, weight), u_reflection_fade);
}
