// Test probe of the shared tile buffers (gl.SlotArena, gl.MeshArena): vertices already in
// clip space, one shade each, coloured so that neighbouring shades differ in every channel.

#ifdef VERTEX
layout(location = 0) in vec3 a_position;
layout(location = 1) in float a_shade;
out float v_shade;
void main() {
    v_shade = a_shade;
    gl_Position = vec4(a_position, 1.0);
}
#endif

#ifdef FRAGMENT
in float v_shade;
out vec4 frag;
void main() {
    frag = vec4(v_shade, fract(v_shade * 7.0), fract(v_shade * 13.0), 1.0);
}
#endif
