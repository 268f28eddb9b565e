#version 330 core
// Shadow-map pass: object depth seen from a light (orthographic u_light: vehicle -> clip).
#if defined VERTEX_SHADER
layout(location = 0) in vec3 in_position;
uniform mat4 u_model;
uniform mat4 u_light;
void main() { gl_Position = u_light * u_model * vec4(in_position, 1.0); }
#elif defined FRAGMENT_SHADER
void main() {}
#endif
