#version 330 core
// Preview window, 3D view: coloured points and lines in the vehicle frame.
#if defined VERTEX_SHADER
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_color;
uniform mat4 u_mvp;
uniform float u_point_size;
out vec3 v_color;
void main() {
    v_color = in_color;
    gl_PointSize = u_point_size;
    gl_Position = u_mvp * vec4(in_position, 1.0);
}
#elif defined FRAGMENT_SHADER
in vec3 v_color;
out vec4 out_color;
void main() { out_color = vec4(v_color, 1.0); }
#endif
