// The wave tile: slopes (RMS 1 per component at level 0) in a 2-D array texture with mips;
// animated tiles cross-fade frame a into frame b.
uniform sampler2DArray u_wave;
uniform ivec2 u_wave_frames;     // (frame a, frame b)
uniform float u_wave_blend;      // weight of frame b
uniform float u_wave_length_m;   // world size of one period [m]

vec2 wave_slopes(vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    vec2 a = textureGrad(u_wave, vec3(uv, float(u_wave_frames.x)), duv_dx, duv_dy).xy;
    if (u_wave_blend <= 0.0) return a;
    vec2 b = textureGrad(u_wave, vec3(uv, float(u_wave_frames.y)), duv_dx, duv_dy).xy;
    // adjacent frames are strongly correlated (a small step of the noise's time axis), so a
    // plain mix keeps the contrast: no variance correction, which would make it pulse
    return mix(a, b, u_wave_blend);
}
