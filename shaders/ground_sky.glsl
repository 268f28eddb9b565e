#version 330 core
// The sky light each ground plane receives past the objects, once per texel of the top-down (sky) map's
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
uniform float u_contact_height; // a part this low over the ground darkens it (metres)
uniform float u_contact_radius; // contact search radius in the under map's units
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

// 1 where a part of an object stands on p (its underside at the ground: a tyre, a foot),
// falling off with that part's height over p (u_contact_height), averaged over a disc of
// u_contact_radius: CONTACT_SAMPLES points spread evenly over it (a sunflower), turned by a
// different angle in each texel, so that no pattern of fixed sample points shows as streaks
// where a tyre's edge crosses them (lit.glsl reads the map through a disc).
const int CONTACT_SAMPLES = 24;
float contact_occlusion(vec3 p, float turn) {
    vec4 s = u_under_matrix * vec4(p, 1.0);
    float occ = 0.0;
    for (int i = 0; i < CONTACT_SAMPLES; ++i) {
        float r = sqrt((float(i) + 0.5) / float(CONTACT_SAMPLES)) * u_contact_radius;
        float a = 2.3999632 * float(i) + 6.2831853 * turn;
        float h = (texture(u_under_map, s.xy + r * vec2(cos(a), sin(a))).r - s.z) * u_under_range;  // 1.0: nothing drawn
        occ += exp(-max(h, 0.0) / u_contact_height);
    }
    return occ / float(CONTACT_SAMPLES);
}

// The share of the sky's light the ground at p receives: the sky it sees past the objects (at
// least 12 %: the light the objects' sides and the ground around throw back), less most of it
// where a part stands on it.
void main() {
    float turn = fract(52.9829189 * fract(dot(gl_FragCoord.xy, vec2(0.00583715, 0.06711056))));
    out_open = mix(0.12, 1.0, sky_visibility(v_world)) * (1.0 - 0.85 * contact_occlusion(v_world, turn));
}
#endif
