// The water's look at a point of its surface, one model for the river's water (water.glsl)
// and the flooded floodplain (terrain.glsl, issue 25), so that the two meet across the old
// bank without a seam: the sky's Fresnel reflection and the sun's glint on the wave normal,
// over the bed seen through water of the given clarity, tinted by the deep water's colour.
// Needs common.glsl.

const vec3 WATER_DEEP = vec3(0.03, 0.19, 0.22);     // the deep water's colour (sun overhead)

// The Fresnel reflectance (Schlick, water's 0.02 at normal incidence) seen from v on normal
// n, faded to nothing at the water's edge (shore: 0 at the edge, 1 from 0.5 m deep).
float water_fresnel(vec3 v, vec3 n, float shore) {
    return (0.02 + 0.98 * pow(1.0 - max(dot(v, n), 0.0), 5.0)) * shore;
}

// The light the water adds over its bed (rgb: the reflection, the sun's glint, the deep
// water's colour) and the share of the bed seen through it (a): the pixel is rgb + a · bed.
vec4 water_look(vec3 v, vec3 n, vec3 reflected, float fresnel, float shore, float depth_m,
                float clarity_m) {
    vec3 h = normalize(v + u_sun_dir);
    float spec = pow(max(dot(n, h), 0.0), 400.0) * 2.0 * shore;
    float clarity = exp(-depth_m / max(clarity_m, 1e-3));
    vec3 deep = WATER_DEEP * (0.4 + 0.6 * max(u_sun_dir.z, 0.0));
    return vec4(fresnel * reflected + SUN_COLOUR * spec + (1.0 - fresnel) * (1.0 - clarity) * deep,
                (1.0 - fresnel) * clarity);
}
