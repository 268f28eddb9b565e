#version 330 core
// ID pass: integer object index (1..K, 0 = none) and object depth at each pixel centre.
#if defined VERTEX_SHADER
layout(location = 0) in vec3 in_position;
uniform mat4 u_model;
uniform mat4 u_view;
uniform mat4 u_proj;
out float v_depth;
void main() {
    vec4 optical = u_view * u_model * vec4(in_position, 1.0);
    v_depth = optical.z;
    gl_Position = u_proj * optical;
}
#elif defined FRAGMENT_SHADER
in float v_depth;
uniform uint u_id;
layout(location = 0) out uint out_id;
layout(location = 1) out float out_depth;
void main() { out_id = u_id; out_depth = v_depth; }
#endif
