#version 330 core
// Multisampled fill of the lit pass (render.py). lit.glsl shaded the light once per pixel, at
// its centre (objects over their planes; the planes alone); this pass rasterises the same
// geometry at 4 samples per pixel and gives every sample its pixel's colour - the colour MSAA
// gives on a GPU - so that the costly lighting runs once per pixel, not once per sample (Mesa's
// llvmpipe shades every sample). Outputs as lit.glsl's. With PLANE defined: the planes' samples
// (a variant of its own, as llvmpipe runs both sides of a branch on a uniform).
//
// With NEIGHBOURS defined: a 1x full-frame pass before it that finds, per pixel, the colour of
// the object's other material nearby (the centre shows one material at most; a sample of the
// pixel can fall on another one, or on the object where the centre missed it): the mean colour
// of the 3 x 3 neighbours that show the first other material found, and its key.
//
// Colours are premultiplied (colour, coverage): where the centre shows glass, lit.glsl left the
// pane over what is behind it (the interior, far panes) with the coverage 1 - the share of the
// photo behind that shows through; every sample of that pane takes both, and the plane's colour
// behind it by the rest. An object is at a pixel centre where its key's alpha is 1 (lit.glsl
// writes the material's base colour factor, whose alpha models.mesh sets to 1; -1 on a plane).
#if defined VERTEX_SHADER
#if defined NEIGHBOURS
void main() {  // one triangle over the whole frame
    vec2 p = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1)) - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#else
layout(location = 0) in vec3 in_position;
layout(location = 3) in vec4 in_color;
uniform mat4 u_model;
uniform mat4 u_view;
uniform mat4 u_proj;
out float v_depth;
out vec4 v_key;
void main() {
    v_key = in_color;
    vec4 optical = u_view * (u_model * vec4(in_position, 1.0));
    v_depth = optical.z;
    gl_Position = u_proj * optical;
}
#endif
#elif defined FRAGMENT_SHADER
#include "plane_ground.glsl"
uniform sampler2D u_object_col;  // (object colour, coverage) where an object covers the pixel centre
uniform sampler2D u_object_key;  // the material there: its base colour factor (lit.glsl's out_key)
bool same(vec4 a, vec4 b) { return all(lessThan(abs(a - b), vec4(1e-3))); }
bool present(vec4 key) { return key.a > 0.5; }

#if defined NEIGHBOURS
layout(location = 0) out vec4 out_colour;  // mean (colour, coverage), or 0 where there is none
layout(location = 1) out vec4 out_key;     // its material, -1 where there is none
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 last = textureSize(u_object_col, 0) - 1;
    vec4 own = texelFetch(u_object_key, p, 0);
    bool covered = present(own);
    vec4 key = vec4(-1.0);
    bool found = false;
    for (int i = 0; i < 9 && !found; ++i) {
        ivec2 q = clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), last);
        vec4 k = texelFetch(u_object_key, q, 0);
        if (present(k) && !(covered && same(k, own))) { key = k; found = true; }
    }
    vec4 sum = vec4(0.0);
    float n = 0.0;
    for (int i = 0; i < 9 && found; ++i) {
        ivec2 q = clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), last);
        if (same(texelFetch(u_object_key, q, 0), key)) { sum += texelFetch(u_object_col, q, 0); n += 1.0; }
    }
    out_colour = n > 0.0 ? sum / n : vec4(0.0);
    out_key = key;
}
#else
in float v_depth;
in vec4 v_key;                   // this fragment's material
uniform sampler2D u_plane_col;   // the planes alone, lit and shadowed, at the pixel centre
uniform sampler2D u_other_col;   // the NEIGHBOURS pass
uniform sampler2D u_other_key;
layout(location = 0) out vec4 out_color;
layout(location = 1) out float out_alpha;
layout(location = 2) out float out_odepth;
layout(location = 3) out vec2 out_plane;
layout(location = 4) out vec4 out_object;

// The object's (colour, coverage) for a sample of this pixel: the centre's where the centre shows
// this material, else the nearby one of this material (an edge of the object, or between two of
// its materials); failing both (a part thinner than a pixel: a window seal, a trim), what the
// pixel shows. (Its base colour under that light looked right on seals but made bright specks
// where the neighbour is glass or chrome, whose colour is mostly reflection.)
vec4 object_colour(ivec2 p) {
    vec4 c = texelFetch(u_object_col, p, 0);
    vec4 k = texelFetch(u_object_key, p, 0);
    if (present(k) && same(k, v_key)) return c;
    vec4 o = texelFetch(u_other_col, p, 0);
    vec4 ok = texelFetch(u_other_key, p, 0);
    if (present(ok) && same(ok, v_key)) return o;
    if (present(k)) return c;
    if (present(ok)) return o;
    return vec4(texelFetch(u_plane_col, p, 0).rgb, 1.0);
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
#if defined PLANE
    if (plane_floats(v_depth)) discard;  // as lit.glsl leaves it out
    out_color = vec4(texelFetch(u_plane_col, p, 0).rgb, 1.0);
    out_alpha = 0.0;
    out_odepth = 0.0;
    out_plane = vec2(v_depth, 1.0);
    out_object = vec4(0.0);
#else
    vec4 c = object_colour(p);
    // behind a pane (c.a < 1): the plane's colour at this pixel (0 where there is none) by the rest
    out_color = vec4(c.rgb + (1.0 - c.a) * texelFetch(u_plane_col, p, 0).rgb, 1.0);
    out_alpha = c.a;
    out_odepth = c.a * v_depth;
    out_plane = vec2(0.0);
    out_object = c;
#endif
}
#endif
#endif
