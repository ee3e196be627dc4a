// A program with a compile error on line 8 of this file (after an include).
#include "common.glsl"
#ifdef VERTEX
void main() { gl_Position = vec4(0.0); }
#endif
#ifdef FRAGMENT
out vec4 frag;
void main() { frag = vec4(undefined_name); }
#endif
