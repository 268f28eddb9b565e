#version 330 core
// Lit pass: the inserted objects and their local ground planes, in linear light.
// Vertex data in the object frame; u_model: vehicle <- object; u_view: optical <- vehicle.
#if defined VERTEX_SHADER
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in vec4 in_color;
layout(location = 4) in vec2 in_material;
uniform mat4 u_model;
uniform mat4 u_view;
uniform mat4 u_proj;
out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_color;
out vec2 v_material;
out float v_depth;
void main() {
    vec4 world = u_model * vec4(in_position, 1.0);
    vec4 optical = u_view * world;
    v_world = world.xyz;
    v_normal = mat3(u_model) * in_normal;
    v_uv = in_uv;
    v_color = in_color;
    v_material = in_material;
    v_depth = optical.z;
    gl_Position = u_proj * optical;
}
#elif defined FRAGMENT_SHADER
#include "common.glsl"
in vec3 v_world;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_color;
in vec2 v_material;
in float v_depth;
uniform bool u_is_plane;        // ground plane (Ir / Irpv) or object
uniform bool u_shadows;         // false for Ir: the plane alone, nothing casts shadows
uniform bool u_has_texture;
uniform sampler2D u_texture;    // sRGB base colour
uniform vec3 u_plane_albedo;    // linear; used when u_plane_from_photo is false
uniform bool u_plane_from_photo; // plane albedo = photo / unshadowed irradiance, per pixel
uniform sampler2D u_photo;      // the photo's region of interest, sRGB
uniform vec3 u_camera_pos;      // vehicle frame
uniform vec3 u_sun_dir;         // vehicle frame, towards the sun
uniform vec3 u_sun_rgb;         // irradiance on a surface facing the sun
uniform vec3 u_sky_rgb;         // ambient from the upper hemisphere
uniform vec3 u_ground_rgb;      // ambient bounced from the ground
uniform sampler2DShadow u_sun_map;
uniform mat4 u_sun_matrix;      // vehicle -> sun shadow map [0,1]^3
uniform sampler2DShadow u_sky_map;
uniform mat4 u_sky_matrix;      // vehicle -> top-down occlusion map [0,1]^3
uniform float u_sky_radius;     // occlusion search radius in map units
layout(location = 0) out vec4 out_color;   // lit linear colour
layout(location = 1) out float out_alpha;  // object coverage
layout(location = 2) out float out_odepth; // object depth (0 on the plane)
layout(location = 3) out vec2 out_plane;   // (plane depth, plane coverage)

const vec2 DISC[12] = vec2[](vec2(-0.326, -0.406), vec2(-0.840, -0.074), vec2(-0.696, 0.457),
    vec2(-0.203, 0.621), vec2(0.962, -0.195), vec2(0.473, -0.480), vec2(0.519, 0.767),
    vec2(0.185, -0.893), vec2(0.507, 0.064), vec2(0.896, 0.412), vec2(-0.322, -0.933),
    vec2(-0.792, -0.598));

float sun_visibility(vec3 p) {
    vec4 s = u_sun_matrix * vec4(p, 1.0);
    float vis = 0.0;
    vec2 texel = 1.0 / vec2(textureSize(u_sun_map, 0));
    for (int i = 0; i < 12; ++i)
        vis += texture(u_sun_map, vec3(s.xy + DISC[i] * 2.0 * texel, s.z - 0.002));
    return vis / 12.0;
}

float sky_visibility(vec3 p) {
    // share of a disc around p with nothing of the objects above it: a soft contact shadow
    vec4 s = u_sky_matrix * vec4(p, 1.0);
    float vis = texture(u_sky_map, vec3(s.xy, s.z - 0.002));
    for (int i = 0; i < 12; ++i)
        vis += texture(u_sky_map, vec3(s.xy + DISC[i] * u_sky_radius, s.z - 0.002));
    return vis / 13.0;
}

void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(u_camera_pos - v_world);
    if (dot(n, v) < 0.0) n = -n;   // two-sided
    vec3 albedo;
    float metallic, roughness;
    if (u_is_plane) {
        metallic = 0.0; roughness = 1.0;
        albedo = u_plane_albedo;
        if (u_plane_from_photo) {
            // projective texturing: the plane alone (Ir) reproduces the photo exactly, so
            // R + Irpv - Ir = R * (shadowed / unshadowed light): shadows darken the real road
            vec3 unshadowed = mix(u_ground_rgb, u_sky_rgb, 0.5 + 0.5 * n.z) + u_sun_rgb * max(dot(n, u_sun_dir), 0.0);
            albedo = srgb_to_linear(texelFetch(u_photo, ivec2(gl_FragCoord.xy), 0).rgb) / max(unshadowed, vec3(1e-4));
        }
    } else {
        albedo = v_color.rgb;
        if (u_has_texture) albedo *= srgb_to_linear(texture(u_texture, v_uv).rgb);
        metallic = v_material.x; roughness = clamp(v_material.y, 0.05, 1.0);
    }
    float sun_vis = u_shadows ? sun_visibility(v_world) : 1.0;
    float sky_vis = 1.0;
    if (u_shadows && u_is_plane) sky_vis = mix(0.35, 1.0, sky_visibility(v_world));
    float ndl = max(dot(n, u_sun_dir), 0.0);
    vec3 ambient = mix(u_ground_rgb, u_sky_rgb, 0.5 + 0.5 * n.z) * sky_vis;
    vec3 diffuse = albedo * (1.0 - metallic) * (ambient + u_sun_rgb * ndl * sun_vis);
    // glossy part: Schlick Fresnel, sky/ground reflection and a Blinn-Phong sun highlight
    vec3 f0 = mix(vec3(0.04), albedo, metallic);
    float ndv = clamp(dot(n, v), 0.0, 1.0);  // pow() of a negative base is undefined
    vec3 fresnel = f0 + (1.0 - f0) * pow(1.0 - ndv, 5.0);
    vec3 r = reflect(-v, n);
    vec3 env = mix(u_ground_rgb, u_sky_rgb, smoothstep(-0.2, 0.2, r.z));
    float gloss = 1.0 - roughness;
    vec3 h = normalize(u_sun_dir + v);
    float shininess = mix(4.0, 512.0, gloss * gloss);
    vec3 spec = u_sun_rgb * sun_vis * pow(max(dot(n, h), 0.0), shininess) * (shininess + 8.0) / 25.0 * ndl;
    vec3 color = diffuse + fresnel * (env * gloss + spec * gloss);
    if (u_is_plane) color = diffuse;
    out_color = vec4(color, 1.0);
    out_alpha = u_is_plane ? 0.0 : 1.0;
    out_odepth = u_is_plane ? 0.0 : v_depth;
    out_plane = u_is_plane ? vec2(v_depth, 1.0) : vec2(0.0);
}
#endif
