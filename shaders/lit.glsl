#version 330 core
// Lit pass: the inserted objects and their local ground planes, in linear light.
// Vertex data in the object frame; u_model: vehicle <- object; u_view: optical <- vehicle.
// The fragment shader comes in variants (render.py compiles each one it draws with), so that
// each runs only its own code: Mesa's llvmpipe runs both sides of a branch on a uniform.
//   PLANE       a ground plane; NO_SHADOWS with it: the plane alone (Ir), nothing casts shadows
//   otherwise   an object part; TEXTURE: it has a base colour texture, NORMAL_MAP: a normal map;
//               GLASS: a pane, drawn after the opaque parts and blended over them (premultiplied,
//               ONE / ONE_MINUS_SRC_ALPHA on every target): it adds what it reflects and keeps of
//               what is behind it (the interior, far panes, the plane, nothing) the share it lets
//               through, so that coverage, depth and colour stay consistent for the compose
//               (a = 1 - what reaches the photo behind the object)
#if defined VERTEX_SHADER
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in vec4 in_color;
layout(location = 4) in vec2 in_material;
layout(location = 5) in vec4 in_tangent;   // bound only for parts with a normal map
uniform mat4 u_model;
uniform mat4 u_view;
uniform mat4 u_proj;
out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_color;
out vec2 v_material;
out vec4 v_tangent;
out float v_depth;
out vec2 v_local;            // the model's own x, y: on a ground plane, its unit square
flat out float v_ground_z;   // height of the object's contact point (reflection proxy)
void main() {
    vec4 world = u_model * vec4(in_position, 1.0);
    vec4 optical = u_view * world;
    v_world = world.xyz;
    v_normal = mat3(u_model) * in_normal;
    v_uv = in_uv;
    v_color = in_color;
    v_material = in_material;
    v_tangent = vec4(mat3(u_model) * in_tangent.xyz, in_tangent.w);
    v_depth = optical.z;
    v_local = in_position.xy;
    v_ground_z = u_model[3].z;
    gl_Position = u_proj * optical;
}
#elif defined FRAGMENT_SHADER
#include "common.glsl"
#include "plane_ground.glsl"
in vec3 v_world;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_color;
in vec2 v_material;
in vec4 v_tangent;              // (tangent along +u, handedness): glTF's TANGENT (models.py)
in float v_depth;
in vec2 v_local;
flat in float v_ground_z;
uniform sampler2D u_texture;    // sRGB base colour (TEXTURE)
uniform sampler2D u_normal_map; // tangent-space normals (linear), glTF's normalTexture
uniform float u_normal_scale;   // its scale: multiplies the map's x and y
uniform vec3 u_plane_albedo;    // linear; used when u_plane_from_photo is false
uniform bool u_plane_from_photo; // plane albedo = photo / unshadowed irradiance, per pixel
uniform sampler2D u_photo;      // the photo's region of interest, sRGB
uniform vec3 u_camera_pos;      // vehicle frame
uniform vec3 u_sun_dir;         // vehicle frame, towards the sun
uniform vec3 u_sun_rgb;         // irradiance on a surface facing the sun
uniform vec3 u_sky_rgb;         // ambient from the upper hemisphere
uniform vec3 u_ground_rgb;      // ambient bounced from the ground
uniform sampler2D u_sun_map;    // depth of the objects seen from the sun (no compare)
uniform mat4 u_sun_matrix;      // vehicle -> sun shadow map [0,1]^3
uniform sampler2D u_sky_map;    // depth of the objects seen from straight above (no compare)
uniform mat4 u_sky_matrix;      // vehicle -> top-down occlusion map [0,1]^3
uniform float u_map_metres;     // metres across every light map (their square's side)
uniform float u_sun_radius;     // tangent of the sun's angular radius
uniform int u_planes_n;         // the ground planes of this render (PLANE, at most MAX_PLANES)
uniform mat4 u_plane_inv[15];   // each one's unit square <- vehicle
uniform vec2 u_plane_halves[15]; // and its half sizes, metres
uniform float u_plane_fade;     // the darkening fades out over this many metres to the planes' edges
uniform sampler2D u_ground_sky; // the sky the ground planes see past the objects (ground_sky.glsl), over the sky map's square
uniform float u_ground_sky_scale; // in its lower left square of this share of its side (shadows.ground_sky_texels)
const float GROUND_SKY_BLUR = 0.25;  // metres
const float GROUND_SKY_PIXELS = 6.0;  // and at least this many pixels' footprint (ground_sky())
uniform sampler2D u_under_map;  // depth of the objects' undersides seen from below (no compare)
uniform mat4 u_under_matrix;    // vehicle -> that map [0,1]^3
uniform float u_under_range;    // metres its depth 0..1 spans
uniform float u_contact_height; // a part this low over the ground darkens it (metres)
uniform float u_contact_radius; // contact search radius in map units
uniform int u_recolour_n;       // materials of this object drawn in other colours (at most 3)
uniform vec4 u_recolour_key[3]; // their base colour factors
uniform vec3 u_recolour_rgb[3]; // and the colours (linear albedo) they get
uniform float u_self_bias;      // a few centimetres in the sky map's depth units (no self-shadow acne)
uniform float u_sun_scale;      // sun reaching this object (0 when it stands in a real cast shadow)
uniform bool u_has_sun_mask;    // the planes take the sun per pixel from u_sun_mask
uniform sampler2D u_sun_mask;   // sun reaching the real ground at each pixel of the ROI (0 in its shadows)
uniform bool u_has_env;         // reflections: sample the photo where the reflected ray lands
uniform sampler2D u_env;        // the full photo (sRGB texture: reads linear), mipmapped
uniform mat4 u_env_view;        // vehicle -> optical frame of the full camera
uniform vec4 u_env_k;           // (fx / W, fy / H, u0 / W, v0 / H) of the full camera
uniform float u_env_lods;       // mip levels of u_env
uniform float u_transmission;   // GLASS: the share of light the pane's material lets through
// The targets hold 1 to 4 channels; every output is a vec4 so that its alpha is the one the
// glass blend uses on that target (only the target's own channels are stored).
layout(location = 0) out vec4 out_color;   // lit linear colour
layout(location = 1) out vec4 out_alpha;   // object coverage
layout(location = 2) out vec4 out_odepth;  // object depth times coverage (0 on the plane)
layout(location = 3) out vec4 out_plane;   // (plane depth, plane coverage)
layout(location = 4) out vec4 out_object;  // (object colour, coverage) on the object, 0 on the plane
layout(location = 5) out vec4 out_key;     // the material's base colour factor (fill.glsl)

const vec2 DISC[12] = vec2[](vec2(-0.326, -0.406), vec2(-0.840, -0.074), vec2(-0.696, 0.457),
    vec2(-0.203, 0.621), vec2(0.962, -0.195), vec2(0.473, -0.480), vec2(0.519, 0.767),
    vec2(0.185, -0.893), vec2(0.507, 0.064), vec2(0.896, 0.412), vec2(-0.322, -0.933),
    vec2(-0.792, -0.598));

// The sun's visibility at p, with the penumbra of a sun of angular radius u_sun_radius: the
// objects' depths seen from the sun within a search disc give the mean blocker's distance d
// above p along the light; the shadow's edge is then d * u_sun_radius soft (radius). The
// filter's disc is widened by the pixel's own footprint on the receiver (half a pixel each
// way, along the two image axes: the camera's blur, and no aliasing of the map where a far
// pixel covers many texels). Percentage-closer filtering over that ellipse.
float sun_visibility(vec3 p) {
    vec4 s = u_sun_matrix * vec4(p, 1.0);
    vec2 a = 0.5 * (mat3(u_sun_matrix) * dFdx(p)).xy;  // half a pixel, in map units
    vec2 b = 0.5 * (mat3(u_sun_matrix) * dFdy(p)).xy;
    float texel = 1.0 / float(textureSize(u_sun_map, 0).x);
    float search = max(0.35 / u_map_metres, 2.0 * max(length(a), length(b)));
    float blockers = 0.0, n = 0.0;
    for (int i = 0; i < 12; ++i) {
        float d = texture(u_sun_map, s.xy + DISC[i] * search).r;
        if (d < s.z - 0.002) { blockers += d; n += 1.0; }
    }
    float d0 = texture(u_sun_map, s.xy).r;
    if (d0 < s.z - 0.002) { blockers += d0; n += 1.0; }
    if (n == 0.0) return 1.0;  // nothing between p and the sun near it
    float distance = (s.z - blockers / n) * u_under_range;  // metres from the blockers to p
    float r = max(distance * u_sun_radius / u_map_metres, texel);
    // the ellipse r^2 I + a a' + b b', by its square root (closed form for a 2 x 2 matrix)
    mat2 cov = mat2(r * r) + outerProduct(a, a) + outerProduct(b, b);
    float sq = sqrt(max(determinant(cov), 0.0));
    mat2 m = (cov + mat2(sq)) / sqrt(max(cov[0][0] + cov[1][1] + 2.0 * sq, 1e-20));
    float vis = step(s.z - 0.002, d0);
    for (int i = 0; i < 12; ++i)
        vis += step(s.z - 0.002, texture(u_sun_map, s.xy + m * DISC[i]).r);
    return vis / 13.0;
}

// The sky the ground at p sees past the objects (ground_sky.glsl), read over a disc of
// GROUND_SKY_BLUR metres, widened to GROUND_SKY_PIXELS of the pixel's own footprint on the
// ground along each image axis: a far object's occlusion, a few rows deep, fades over as many
// pixels as a near one's rather than in one step at its bumper's line.
float ground_sky(vec3 p) {
    vec2 g = u_ground_sky_scale * (u_sky_matrix * vec4(p, 1.0)).xy;
    vec2 a = u_ground_sky_scale * GROUND_SKY_PIXELS * (mat3(u_sky_matrix) * dFdx(p)).xy;
    vec2 b = u_ground_sky_scale * GROUND_SKY_PIXELS * (mat3(u_sky_matrix) * dFdy(p)).xy;
    float r = u_ground_sky_scale * GROUND_SKY_BLUR / u_map_metres;
    mat2 cov = mat2(r * r) + outerProduct(a, a) + outerProduct(b, b);
    float sq = sqrt(max(determinant(cov), 0.0));
    mat2 m = (cov + mat2(sq)) / sqrt(max(cov[0][0] + cov[1][1] + 2.0 * sq, 1e-20));
    float open = texture(u_ground_sky, g).r;
    for (int i = 0; i < 12; ++i)
        open += texture(u_ground_sky, g + m * DISC[i]).r;
    return open / 13.0;
}

// The objects' darkening fades out before the edges of the ground the planes cover together,
// no outline of a receiver: at p, the largest of the planes' fades (each one's over u_plane_fade
// metres to its own edges). Where one plane's edge crosses another's darkening (two cars side by
// side), the darkening goes on: whichever plane is drawn there shades the ground alike.
float plane_fade(vec3 p) {
    float fade = 0.0;
    for (int k = 0; k < u_planes_n; ++k) {
        vec2 edge = (1.0 - abs((u_plane_inv[k] * vec4(p, 1.0)).xy)) * u_plane_halves[k];
        fade = max(fade, smoothstep(0.0, u_plane_fade, min(edge.x, edge.y)));
    }
    return fade;
}

float contact_occlusion(vec3 p) {
    // 1 where a part of an object stands on p (its underside at the ground: a tyre, a foot),
    // falling off with that part's height over p (u_contact_height), averaged over a small disc
    vec4 s = u_under_matrix * vec4(p, 1.0);
    float occ = 0.0;
    for (int i = 0; i < 13; ++i) {
        vec2 q = s.xy + (i == 12 ? vec2(0.0) : DISC[i] * u_contact_radius);
        float h = (texture(u_under_map, q).r - s.z) * u_under_range;  // 1.0: nothing drawn
        occ += exp(-max(h, 0.0) / u_contact_height);
    }
    return occ / 13.0;
}

// The sky a point of an object sees: less near the ground (the ground and the object itself
// hide it), and less under a part of the object (a wheel under its arch, the sides under the
// waist line): its ambient light and reflections fall off there.
float object_occlusion(vec3 p, float height) {
    vec4 s = u_sky_matrix * vec4(p, 1.0);
    float open = step(s.z - u_self_bias, texture(u_sky_map, s.xy).r);
    for (int i = 0; i < 6; ++i)  // a few centimetres around: no jagged edge where it turns
        open += step(s.z - u_self_bias, texture(u_sky_map, s.xy + DISC[i] * 0.3 * u_contact_radius).r);
    return mix(0.35, 1.0, smoothstep(0.0, 0.4, height)) * mix(0.4, 1.0, open / 7.0);
}

// Radiance reflected towards the camera from direction r at p: the photo where the ray lands on
// a simple proxy of the scene (the ground plane below, a wall 30 m away otherwise), projected
// into the full frame and blurred with the roughness (mip level). Where the ray leaves the frame
// (behind the camera, above the image, to the sides) the street is taken to look like the part
// of it in the frame: the point is folded back into the frame's angles (a mirror at each edge),
// and the steepest rays up see the open sky. So paint and glass reflect textured surroundings,
// as real ones do, not one flat colour.
vec3 environment(vec3 p, vec3 r, float roughness) {
    vec3 fallback = mix(u_ground_rgb, u_sky_rgb, smoothstep(-0.2, 0.2, r.z));
    if (!u_has_env) return fallback;
    float t = 30.0;
    if (r.z < -0.02) t = min((v_ground_z - p.z) / r.z, 30.0);
    vec4 o = u_env_view * vec4(p + max(t, 0.0) * r, 1.0);
    // the frame's angular extent along its x and y axes; a point outside it (behind the camera,
    // above the image, to the sides) is folded back into it, angles kept: the street behind and
    // above the frame looks like the street in it
    vec2 lo = atan(-u_env_k.zw / u_env_k.xy);
    vec2 hi = atan((1.0 - u_env_k.zw) / u_env_k.xy);
    vec2 a = vec2(atan(o.x, abs(o.z)), atan(o.y, abs(o.z)));
    vec2 x = (a - lo) / (hi - lo);
    a = lo + (hi - lo) * (1.0 - abs(mod(x, 2.0) - 1.0));
    vec2 uv = u_env_k.xy * tan(a) + u_env_k.zw;
    // the lookup's footprint: where the next pixels' rays land far apart in the photo (a curved
    // or coarsely modelled panel), the pixel reflects all of the photo between them, not one
    // sharp point of it (the aliased shards and jagged lines of a crease). A texture seen
    // directly gets that filtering; textureLod's explicit level turns it off. The level whose
    // texels are half the step to the next pixel's ray: its linear taps, two texels wide, then
    // span the step. The derivatives are taken before any return (uniform control flow)
    vec2 texels = vec2(textureSize(u_env, 0));
    float footprint = max(length(dFdx(uv) * texels), length(dFdy(uv) * texels));
    float lod = max(roughness * u_env_lods, log2(max(footprint, 2.0)) - 1.0);
    if (dot(o.xyz, o.xyz) < 0.25) return fallback;
    vec3 photo = textureLod(u_env, uv, clamp(lod, 0.0, u_env_lods)).rgb;
    // steeply upwards: the open sky between the roofs
    return mix(photo, u_sky_rgb, smoothstep(0.75, 1.0, r.z));
}

// The shading normal from the normal map, in the tangent frame (T, B, N) of the side seen:
// n is the interpolated normal already turned towards the viewer, side -1 when it was turned
// (a back face turns T and B too); B = w * (N x T) points to -v, up in the map (glTF).
vec3 normal_from_map(vec3 n, float side) {
    vec3 t = side * v_tangent.xyz;
    t -= n * dot(n, t);
    if (dot(t, t) < 1e-12) return n;
    t = normalize(t);
    vec3 b = side * v_tangent.w * cross(n, t);
    vec3 m = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;
    m.xy *= u_normal_scale;
    return normalize(mat3(t, b, n) * m);
}

void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(u_camera_pos - v_world);
    if (dot(n, v) < 0.0) n = -n;   // two-sided
    float ndl = max(dot(n, u_sun_dir), 0.0);
#if defined PLANE
    // the sun that reaches the plane: the real ground's own where u_sun_mask is given (so a
    // shadow thrown onto ground already in a real shadow adds nothing, and overlapping planes
    // shade alike)
    float sun_scale = u_sun_scale;
    if (u_has_sun_mask) sun_scale = texelFetch(u_sun_mask, ivec2(gl_FragCoord.xy), 0).r;
    vec3 albedo = u_plane_albedo;
    if (u_plane_from_photo) {
        // projective texturing: the plane alone (Ir) reproduces the photo exactly, so
        // R + Irpv - Ir = R * (shadowed / unshadowed light): shadows darken the real road
        vec3 unshadowed = mix(u_ground_rgb, u_sky_rgb, 0.5 + 0.5 * n.z) + u_sun_rgb * sun_scale * max(dot(n, u_sun_dir), 0.0);
        albedo = srgb_to_linear(texelFetch(u_photo, ivec2(gl_FragCoord.xy), 0).rgb) / max(unshadowed, vec3(1e-4));
    }
#if defined NO_SHADOWS
    float sun_vis = 1.0;
    float sky_vis = 1.0;
#else
    float fade = plane_fade(v_world);
    float sun_vis = mix(1.0, sun_visibility(v_world), fade);
    float open = ground_sky(v_world);
    float sky_vis = mix(1.0, mix(0.12, 1.0, open) * (1.0 - 0.85 * contact_occlusion(v_world)), fade);
#endif
    vec3 ambient = mix(u_ground_rgb, u_sky_rgb, 0.5 + 0.5 * n.z) * sky_vis;
    vec3 sun_rgb = u_sun_rgb * sun_scale;
    vec3 color = albedo * (ambient + sun_rgb * ndl * sun_vis);
    out_color = vec4(color, 1.0);
    out_alpha = vec4(0.0, 0.0, 0.0, 1.0);
    out_odepth = vec4(0.0, 0.0, 0.0, 1.0);
    out_plane = vec4(v_depth, 1.0, 0.0, 1.0);
    out_object = vec4(0.0);
    out_key = vec4(-1.0);
    if (plane_floats(v_depth)) discard;  // after the derivatives above (plane_ground.glsl)
#else
    // looked up a little off the surface along its normal, so that a face is not under itself
    float occlusion = object_occlusion(v_world + 0.1 * n, v_world.z - v_ground_z);
#if defined NORMAL_MAP
    n = normal_from_map(n, dot(n, v_normal) < 0.0 ? -1.0 : 1.0);
    ndl = max(dot(n, u_sun_dir), 0.0);
#endif
    float roughness = clamp(v_material.y, 0.05, 1.0);
    float sun_vis = sun_visibility(v_world);
    vec3 sun_rgb = u_sun_rgb * u_sun_scale;
    float ndv = clamp(dot(n, v), 0.0, 1.0);  // pow() of a negative base is undefined
    vec3 r = reflect(-v, n);
    vec3 env = environment(v_world, r, roughness) * occlusion;
    float gloss = 1.0 - roughness;
    vec3 h = normalize(u_sun_dir + v);
    float shininess = mix(4.0, 512.0, gloss * gloss);
    vec3 spec = sun_rgb * sun_vis * pow(max(dot(n, h), 0.0), shininess) * (shininess + 8.0) / 25.0 * ndl;
#if defined GLASS
    // a thin pane (n = 1.5, Schlick): each face reflects f, the two together 2f / (1 + f); of the
    // rest the material lets u_transmission through and scatters the remainder in its own
    // colour (a tinted lens, a dirty pane: alpha blending's share). Premultiplied: reflection and
    // scattered light are added, 1 - cover of what is behind is kept (the blend), on colour,
    // coverage and depth alike.
    float f = 0.04 + 0.96 * pow(1.0 - ndv, 5.0);
    float reflected = 2.0 * f / (1.0 + f);
    vec3 ambient = mix(u_ground_rgb, u_sky_rgb, 0.5 + 0.5 * n.z) * occlusion;
    vec3 scattered = v_color.rgb * (ambient + sun_rgb * ndl * sun_vis);
    float cover = 1.0 - (1.0 - reflected) * u_transmission;
    vec3 color = reflected * (env * gloss + spec * gloss) + (1.0 - reflected) * (1.0 - u_transmission) * scattered;
    out_color = vec4(color, cover);
    out_alpha = vec4(cover, 0.0, 0.0, cover);
    out_odepth = vec4(cover * v_depth, 0.0, 0.0, cover);
    out_plane = vec4(0.0);  // the plane behind keeps what it had
    out_object = vec4(color, cover);
    out_key = v_color;
#else
    vec3 albedo = v_color.rgb;
    for (int i = 0; i < u_recolour_n; ++i)  // this object's paint or clothes (appearance.py)
        if (all(lessThan(abs(v_color - u_recolour_key[i]), vec4(1e-3)))) albedo = u_recolour_rgb[i];
#if defined TEXTURE
    albedo *= srgb_to_linear(texture(u_texture, v_uv).rgb);
#endif
    float metallic = v_material.x;
    vec3 ambient = mix(u_ground_rgb, u_sky_rgb, 0.5 + 0.5 * n.z) * occlusion;
    vec3 diffuse = albedo * (1.0 - metallic) * (ambient + sun_rgb * ndl * sun_vis);
    // glossy part: Schlick Fresnel, sky/ground reflection and a Blinn-Phong sun highlight
    vec3 f0 = mix(vec3(0.04), albedo, metallic);
    vec3 fresnel = f0 + (1.0 - f0) * pow(1.0 - ndv, 5.0);
    vec3 color = diffuse + fresnel * (env * gloss + spec * gloss);
    out_color = vec4(color, 1.0);
    out_alpha = vec4(1.0);
    out_odepth = vec4(v_depth, 0.0, 0.0, 1.0);
    out_plane = vec4(0.0);
    out_object = vec4(color, 1.0);
    out_key = v_color;
#endif
#endif
}
#endif
