// Where a ground plane is the ground: not where it floats over the real ground. An object on a
// footway has its plane at the footway's height, reaching as far as its shadow does, over the
// road too; there it hovers a kerb's height over the road, nearer to the camera than the road
// by about that height over the camera's, and wins the depth test against the plane of a car
// standing on that road: the car's foot then read the ground's light at the hovering point,
// a metre from where the road is (a lit box behind a car). Such fragments are left out, so the
// plane under them shows. u_scene_depth: the real scene's nearest depth within a few pixels
// (metres, 0 where unknown; render.Renderer.render), so that the stereo's far specks leave no hole.
uniform sampler2D u_scene_depth;
uniform bool u_has_scene_depth;
const float PLANE_FLOAT = 0.06;  // nearer than the real ground by this share of its depth: floating
bool plane_floats(float depth) {
    if (!u_has_scene_depth) return false;
    float real = texelFetch(u_scene_depth, ivec2(gl_FragCoord.xy), 0).r;
    return real > 0.0 && depth < real * (1.0 - PLANE_FLOAT);
}
