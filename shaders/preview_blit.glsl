#version 330 core
// Preview window: one RGB image over the whole viewport (texture row 0 = image top).
// With OVERLAY defined: an RGBA picture (straight alpha) to blend over what is drawn.
#if defined VERTEX_SHADER
out vec2 v_uv;
void main() {
    vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
    v_uv = vec2(p.x * 0.5 + 0.5, 0.5 - p.y * 0.5);
    gl_Position = vec4(p, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
in vec2 v_uv;
uniform sampler2D u_image;
out vec4 out_color;
#if defined OVERLAY
void main() { out_color = texture(u_image, v_uv); }
#else
void main() { out_color = vec4(texture(u_image, v_uv).rgb, 1.0); }
#endif
#endif
