#version 330 core
// The sky each ground plane sees past the objects, once per texel of the top-down (sky) map's
// square rather than once per pixel: the planes are drawn into that square seen from straight
// above, each fragment at its own plane's height. lit.glsl (PLANE) reads it back, bilinearly.
#if defined VERTEX_SHADER
layout(location = 0) in vec3 in_position;
uniform mat4 u_model;      // vehicle <- the plane's unit square
uniform mat4 u_sky_clip;   // vehicle -> the sky map's clip space
out vec3 v_world;
void main() {
    vec4 world = u_model * vec4(in_position, 1.0);
    v_world = world.xyz;
    gl_Position = u_sky_clip * world;
}
#elif defined FRAGMENT_SHADER
in vec3 v_world;
uniform sampler2D u_sky_map;    // depth of the objects seen from straight above (no compare)
uniform mat4 u_sky_matrix;      // vehicle -> that map [0,1]^3
uniform sampler2D u_under_map;  // depth of the objects' undersides seen from below (no compare)
uniform mat4 u_under_matrix;    // vehicle -> that map [0,1]^3
uniform float u_under_range;    // metres the maps' depth 0..1 spans
out float out_open;

// The sky a ground point at p sees past the objects: over 12 directions, the band of elevations
// the objects hide in each (from the lowest their undersides come down to, seen from the nearest
// of them, up to the highest their tops rise to), each direction's share of the cosine-weighted
// sky being what lies below and above that band (sin^2 and cos^2 of its ends). Under a car's
// body only the gap to the ground lets the sky in; at its foot half the sky is gone; further
// away less. A top's rise counts less with its distance, to nothing at SKY_REACH, so the
// darkening ends smoothly well inside the plane (values.PLANE_MARGIN).
const float SKY_REACH = 1.4;
const float SKY_STEPS[5] = float[](0.05, 0.15, 0.33, 0.6, 1.0);
float sky_visibility(vec3 p) {
    float sz = (u_sky_matrix * vec4(p, 1.0)).z;
    float bz = (u_under_matrix * vec4(p, 1.0)).z;
    float open = 0.0;
    // 12 directions, turned by a different fraction of their spacing in each texel (lit.glsl
    // reads the map through a small disc: no polygonal contours from fixed directions)
    float turn = fract(52.9829189 * fract(dot(gl_FragCoord.xy, vec2(0.06711056, 0.00583715))));
    for (int i = 0; i < 12; ++i) {
        float a = 0.5235988 * (float(i) + turn);
        vec3 dir = vec3(cos(a), sin(a), 0.0);
        float top = 0.0;      // tangent of the band's top
        float low = 1e6;      // tangent of its bottom (the gap under the objects)
        for (int k = 0; k < 5; ++k) {
            float r = SKY_STEPS[k];
            vec3 q = p + dir * r;
            float rise = (sz - texture(u_sky_map, (u_sky_matrix * vec4(q, 1.0)).xy).r) * u_under_range;
            if (rise <= 0.0) continue;  // nothing above the ground there
            float fall = 1.0 - (r / SKY_REACH) * (r / SKY_REACH);
            fall *= fall;  // and its slope: no crease where the darkening ends
            top = max(top, rise / r * fall);
            float gap = max((texture(u_under_map, (u_under_matrix * vec4(q, 1.0)).xy).r - bz) * u_under_range, 0.0);
            low = min(low, gap / r);
        }
        float below = low >= 1e5 ? 0.0 : low * low / (1.0 + low * low);  // sin^2 of the band's bottom
        open += min(below + 1.0 / (1.0 + top * top), 1.0);
    }
    return open / 12.0;
}

void main() {
    out_open = sky_visibility(v_world);
}
#endif
