#version 330 core
// Differential-rendering composition of one region of interest, in linear light:
//   R' = a * Irpv + (1 - a) * (R + Irpv - Ir)
// a is the object's coverage where it is in front of the real scene; the real scene keeps
// its pixels (colour, labels, instances, disparity) wherever it is in front.
#if defined VERTEX_SHADER
void main() {
    vec2 p = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1)) - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
#include "common.glsl"
uniform sampler2D u_photo;         // R, sRGB 8-bit
uniform sampler2D u_irpv;          // object + plane, linear
uniform sampler2D u_ir;            // plane alone, linear
uniform sampler2D u_alpha;         // object coverage
uniform sampler2D u_odepth;        // coverage-weighted object depth
uniform sampler2D u_plane;         // (coverage-weighted plane depth, plane coverage)
uniform usampler2D u_id;           // object index at the pixel centre (0 = none) | part label << 8
uniform sampler2D u_id_depth;      // object depth at the pixel centre
uniform sampler2D u_scene_depth;   // real depth, +inf where unknown
uniform usampler2D u_labels;       // real label ids
uniform usampler2D u_instances;    // real instance ids
uniform usampler2D u_disparity;    // real disparity, Cityscapes encoding
uniform uint u_class[16];          // label id of object k (index 1..15)
uniform uint u_instance[16];       // new instance id of object k
uniform uint u_front_labels[8];    // bit set: label always in front (ego vehicle, borders)
uniform float u_disp_scale;        // baseline * fx * 256
uniform float u_tol_abs;           // depth tolerance, metres
uniform float u_tol_rel;           // depth tolerance, fraction of depth
// camera match (off by default): the inserted object gets the photo's blur and noise
uniform sampler2D u_objc;          // object colour premultiplied by coverage (rgb), coverage (a)
uniform sampler2D u_noise;         // standard normal noise per channel (seeded, from NumPy): the band's rows
uniform vec3 u_noise_sigma;        // the photo's noise, sRGB [0, 1] units; 0: no noise
uniform float u_blur_sigma;        // Gaussian blur of the object layer, pixels
uniform int u_blur_radius;         // its half width in pixels; 0: no blur
uniform vec2 u_tone[16];           // camera look of object k: (gain, saturation) on its linear colour
uniform sampler2D u_layer_obj;     // layers() of every pixel (the LAYERS pass), when blurring
uniform sampler2D u_layer_bg;
// a large region is composed in bands of rows (compose.Composer): the region's pixel at this
// framebuffer's (0, 0), and at the layer textures' (0, 0); (0, 0) when it is done whole
uniform ivec2 u_origin;
uniform ivec2 u_layer_origin;
// the real scene's layers (photo, depth, labels, ground, instances, disparity) are made for the rows a
// band reads: the region's pixel at their (0, 0)
uniform ivec2 u_scene_origin;

uniform usampler2D u_ground;       // 1 where the real scene is ground the objects stand on
uniform float u_ground_band;       // K sigma_d / (f B): the real ground's depth error is this * z^2
uniform float u_ground_rel;        // and at least this share of the depth

// In front of the real scene at a pixel. Over real ground, whose stereo depth errs by
// sigma_z = z^2 sigma_d / (f B) (with heavier tails: streaks, mismatches), the band widens to
// K sigma_z, and at least u_ground_rel of the depth: the ground an object stands on and its
// shadow falls on cannot hide them, however noisy its depth (else the shadow and the tyres'
// feet come out speckled where the noise brings the ground nearer).
bool in_front(float obj_depth, float scene_depth, bool label_front, bool ground) {
    float band = ground ? max(u_ground_band * obj_depth, u_ground_rel) * obj_depth : 0.0;
    return !label_front && obj_depth < scene_depth + max(u_tol_abs + u_tol_rel * obj_depth, band);
}

bool label_in_front(uint label) {
    return (u_front_labels[label >> 5u] & (1u << (label & 31u))) != 0u;
}

// The tone of the object at pixel q: its index at the pixel centre, or a neighbour's at an edge
// the centre misses; identity where none is found.
vec2 tone_at(ivec2 q) {
    ivec2 hi = textureSize(u_id, 0) - 1;
    for (int i = 0; i < 9; ++i) {
        ivec2 r = clamp(q + ivec2((i + 4) % 3 - 1, (i + 4) / 3 % 3 - 1), ivec2(0), hi);
        uint id = texelFetch(u_id, r, 0).r & 255u;
        if (id > 0u) return u_tone[id];
    }
    return vec2(1.0);
}

// the share of the photo that must show through an object's panes for its disparity to be kept
const float SEE_THROUGH = 0.1;

// Pixel q and its four neighbours all show object id (pixel centres): not at its silhouette's edge.
bool inside(ivec2 q, uint id) {
    ivec2 hi = textureSize(u_id, 0) - 1;
    for (int i = 0; i < 4; ++i) {
        ivec2 r = clamp(q + ivec2(i == 0 ? 1 : (i == 1 ? -1 : 0), i == 2 ? 1 : (i == 3 ? -1 : 0)), ivec2(0), hi);
        if (texelFetch(u_id, r, 0).r != id) return false;
    }
    return true;
}

// What the compose needs at pixel q, fetched once: the photo R (linear), the passes, the real
// depth and label, and whether the object and its plane are seen in front of the real scene.
struct Pixel {
    vec3 R, irpv, ir, c;
    float a, sd;
    uint label;
    bool front, ground, obj_vis, plane_vis;
};

Pixel fetch(ivec2 q) {
    Pixel x;
    x.R = srgb_to_linear(texelFetch(u_photo, q - u_scene_origin, 0).rgb);
    x.irpv = texelFetch(u_irpv, q, 0).rgb;
    x.c = texelFetch(u_objc, q, 0).rgb;
    x.ir = texelFetch(u_ir, q, 0).rgb;
    x.a = texelFetch(u_alpha, q, 0).r;
    vec2 plane = texelFetch(u_plane, q, 0).rg;
    x.sd = texelFetch(u_scene_depth, q - u_scene_origin, 0).r;
    x.label = texelFetch(u_labels, q - u_scene_origin, 0).r;
    x.front = label_in_front(x.label);
    x.ground = texelFetch(u_ground, q - u_scene_origin, 0).r != 0u;
    x.obj_vis = x.a > 0.0 && in_front(texelFetch(u_odepth, q, 0).r / max(x.a, 1e-6), x.sd, x.front, x.ground);
    x.plane_vis = plane.g > 0.0 && in_front(plane.r / plane.g, x.sd, x.front, x.ground);
    if (x.a > 0.0) {
        // the camera's look on the object (its share of Irpv): gain and saturation in linear light
        vec2 t = tone_at(q);
        float y = dot(x.c, LUMA);
        vec3 toned = t.x * max(vec3(y) + t.y * (x.c - vec3(y)), vec3(0.0));
        x.irpv += toned - x.c;
        x.c = toned;
    }
    return x;
}

// At pixel q: the visible object layer (premultiplied colour, coverage; zero where the real scene
// is in front) and the background behind it (the photo with the inserted shadow). With these,
// R' = C + (1 - a) B is the formula of main() below, rearranged.
void layers(ivec2 q, out vec4 obj, out vec3 bg) {
    Pixel x = fetch(q);
    if (x.obj_vis) {
        vec3 c = x.c;
        obj = vec4(c, x.a);
        // Irpv = C + (1 - a) * shadowed plane; where the object covers all, B is not known
        bg = x.a < 0.999 ? x.R + (x.irpv - c) / (1.0 - x.a) - x.ir : x.R;
    } else {
        obj = vec4(0.0);
        bg = x.R + ((x.a == 0.0 && x.plane_vis) ? x.irpv - x.ir : vec3(0.0));
    }
}

// The composite with the object layer blurred by a Gaussian of u_blur_sigma: C_b + (1 - a_b) B,
// B sharp (it is the photo); under a fully covered pixel B comes from the uncovered neighbours.
// The layers of every pixel come from the LAYERS pass (u_layer_obj, u_layer_bg): worked out
// once per pixel instead of once per pixel and tap.
vec3 blurred(ivec2 p, out float cover) {
    vec4 obj0 = texelFetch(u_layer_obj, p - u_layer_origin, 0);
    vec3 bg0 = texelFetch(u_layer_bg, p - u_layer_origin, 0).rgb;
    bool covered = obj0.a >= 0.999;
    ivec2 hi = textureSize(u_alpha, 0) - 1;  // the region (the photo is made for the band)
    if (!covered) {
        // no object within reach: the blur below adds nothing and B = bg0, exactly (most of
        // the region of interest is the planes around the objects)
        bool near = false;
        for (int dy = -u_blur_radius; dy <= u_blur_radius; ++dy)
            for (int dx = -u_blur_radius; dx <= u_blur_radius; ++dx)
                near = near || texelFetch(u_alpha, clamp(p + ivec2(dx, dy), ivec2(0), hi), 0).r != 0.0;
        if (!near) {
            cover = 0.0;
            return bg0;
        }
    }
    vec4 acc = vec4(0.0);
    vec3 bg_acc = vec3(0.0);
    float wsum = 0.0, bg_w = 0.0;
    float k = -0.5 / (u_blur_sigma * u_blur_sigma);
    for (int dy = -u_blur_radius; dy <= u_blur_radius; ++dy) {
        for (int dx = -u_blur_radius; dx <= u_blur_radius; ++dx) {
            ivec2 q = clamp(p + ivec2(dx, dy), ivec2(0), hi);
            float w = exp(k * float(dx * dx + dy * dy));
            wsum += w;
            if (!covered && texelFetch(u_alpha, q, 0).r == 0.0) continue;  // nothing to add
            vec4 obj = texelFetch(u_layer_obj, q - u_layer_origin, 0);
            vec3 bg = texelFetch(u_layer_bg, q - u_layer_origin, 0).rgb;
            acc += w * obj;
            if (covered && obj.a < 0.999) {
                bg_acc += w * (1.0 - obj.a) * bg;
                bg_w += w * (1.0 - obj.a);
            }
        }
    }
    acc /= wsum;
    vec3 B = covered ? (bg_w > 0.0 ? bg_acc / bg_w : bg0) : bg0;
    cover = acc.a;
    return acc.rgb + (1.0 - acc.a) * B;
}

#if defined LAYERS
// The blur's first pass: each pixel's layers, for blurred() to read.
layout(location = 0) out vec4 out_obj;
layout(location = 1) out vec4 out_bg;
void main() {
    vec4 obj;
    vec3 bg;
    layers(ivec2(gl_FragCoord.xy) + u_origin, obj, bg);
    out_obj = obj;
    out_bg = vec4(bg, 1.0);
}
#else
layout(location = 0) out vec4 out_rgb;
#if !defined RGB_ONLY
layout(location = 1) out uint out_label;
layout(location = 2) out uint out_instance;
layout(location = 3) out uint out_disparity;
layout(location = 4) out uint out_visible;   // object index where it is seen, else 0
#endif

// The 8-bit output level of a pixel (sRGB [0, 1]): the photo's own level where the composite
// keeps it (within 1/50 of a level), else each channel's level rounded down or up, so that the
// pixel's luminance is the composite's on average. Plain rounding to the nearest level turns a
// smooth darkening into bands of whole levels whose borders run as sharp lines along the
// shadow's iso-lines (on a dark road one level is 3 % of its light): where the inserted shadow
// fades out, the last level ends in one straight step around the car. Rounding all three
// channels up or down together at random mixes the levels over the fade, but leaves the pixels
// a whole level apart in luminance: grain no real shadow has. The eight colours one level apart
// around the composite (each channel down or up) have eight luminances 0.07-0.72 of a level
// apart (the channels' weights); the pixel takes one of the two that bracket the composite's
// luminance, at random with the odds that make the mean exact: no band, and grain a few times
// finer, in colour by at most one level a channel. The random number is a hash of the pixel:
// the same output from the same input on any machine.
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
vec3 quantize(vec3 srgb, vec3 photo, ivec2 p) {
    vec3 levels = (srgb - photo) * 255.0;
    if (all(lessThan(abs(levels), vec3(0.02)))) return photo;
    vec3 down = clamp(photo + floor(levels) / 255.0, 0.0, 1.0);
    vec3 up = clamp(photo + (floor(levels) + 1.0) / 255.0, 0.0, 1.0);
    vec3 y_down = LUMA * srgb_to_linear(down), y_up = LUMA * srgb_to_linear(up);
    float target = dot(LUMA, srgb_to_linear(srgb));
    float below = -1.0, above = 1e9;
    vec3 c_below = down, c_above = up;
    for (int k = 0; k < 8; ++k) {
        bvec3 pick = bvec3((k & 1) != 0, (k & 2) != 0, (k & 4) != 0);
        float y = dot(mix(y_down, y_up, pick), vec3(1.0));
        if (y <= target && y > below) { below = y; c_below = mix(down, up, pick); }
        if (y >= target && y < above) { above = y; c_above = mix(down, up, pick); }
    }
    if (below < 0.0) return c_above;
    if (above > 1e8) return c_below;
    float u = float(pcg_hash(uint(p.x) + pcg_hash(uint(p.y))) >> 8u) / 16777216.0;
    return (above > below && u * (above - below) < target - below) ? c_above : c_below;
}

// Variants (compose.Composer): BLUR when the object layer is blurred (u_blur_radius > 0: the
// composite comes from the LAYERS pass's layers, not from this pixel's fetch); RGB_ONLY for a
// view whose labels are not written (the right view of a stereo pair): the colour alone.
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy) + u_origin;
#if defined BLUR
    float cover;
    vec3 rgb = blurred(p, cover);
#else
    Pixel x = fetch(p);
    // Irpv and Ir are resolved over 4 samples with a zero background, so at an object's
    // edge Irpv = a * object + (1 - a) * plane and the formula blends exactly.
    vec3 diff = x.irpv - x.ir;
    float a = x.a;
    if (!x.obj_vis) {
        // hidden (or absent) object: keep R, plus the shadow where the plane itself is seen
        diff = (a == 0.0 && x.plane_vis) ? diff : vec3(0.0);
        a = 0.0;
    }
    vec3 rgb = a * x.irpv + (1.0 - a) * (x.R + diff);
    float cover = a;
#endif
    vec3 srgb = linear_to_srgb(rgb);
    if (cover > 0.0 && any(greaterThan(u_noise_sigma, vec3(0.0)))) {
        // the photo's noise where the object replaces it: what the background keeps of its own
        // noise, (1 - cover), and the added noise make up the photo's level
        float share = sqrt(max(1.0 - (1.0 - cover) * (1.0 - cover), 0.0));
        srgb = clamp(srgb + u_noise_sigma * texelFetch(u_noise, p - u_origin, 0).rgb * share, 0.0, 1.0);
    }
    out_rgb = vec4(quantize(srgb, texelFetch(u_photo, p - u_scene_origin, 0).rgb, p), 1.0);
#if !defined RGB_ONLY
    uint label = texelFetch(u_labels, p - u_scene_origin, 0).r;
    uint raw = texelFetch(u_id, p, 0).r;
    uint id = raw & 255u;
    uint part = raw >> 8u;  // a part labelled apart from its object (a sign's pole): its class, no instance
    out_label = label;
    out_instance = texelFetch(u_instances, p - u_scene_origin, 0).r;
    out_disparity = texelFetch(u_disparity, p - u_scene_origin, 0).r;
    out_visible = 0u;
    if (id > 0u) {
        float od = texelFetch(u_id_depth, p, 0).r;
        if (in_front(od, texelFetch(u_scene_depth, p - u_scene_origin, 0).r, label_in_front(label), texelFetch(u_ground, p - u_scene_origin, 0).r != 0u)) {
            out_label = part > 0u ? part : u_class[id];
            out_instance = part > 0u ? part : u_instance[id];
            out_disparity = uint(clamp(floor(u_disp_scale / od + 0.5) + 1.0, 1.0, 65535.0));
            out_visible = id;
            // through the object's panes (inside its silhouette, not at its edge) the photo behind
            // shows: a camera, and a stereo matcher, see through clear glass to it, so the
            // disparity is the photo's there (the labels stay the object's: Cityscapes labels a
            // car's windows as the car); behind a pane with the interior behind it (a = 1), the
            // object's
            if (texelFetch(u_alpha, p, 0).r < 1.0 - SEE_THROUGH && inside(p, id))
                out_disparity = texelFetch(u_disparity, p - u_scene_origin, 0).r;
        }
    }
#endif
}
#endif  // LAYERS
#endif
