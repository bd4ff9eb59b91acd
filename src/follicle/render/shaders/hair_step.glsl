// One point of a hair on its way to the screen: a Catmull-Rom step in the geometry
// shader, or a vertex in the line vertex shader (hair_line_vs.glsl, one step a segment).
// It faces the viewer (Le Muzic 2012 §5.2.2), gets its coverage and, with SHADE, its shade;
// hair_step fills the varyings (gs_out) but the position and v, and returns the
// ribbon's half-width offset (zero with LINES).
uniform mat4 view_proj;
uniform vec4 eye;            // w = 1: camera position; w = 0: unit direction to the viewer
uniform vec3 view_forward;
uniform vec3 view_right;
uniform float pixel_scale;   // world size of a pixel: per metre of depth (w = 1), or flat
uniform vec2 viewport;       // pixels
uniform bool line_stretch;   // aliased lines: one fragment per pixel along the major axis

float pixel_size(vec3 p) {
    return eye.w > 0.5 ? pixel_scale * max(dot(p - eye.xyz, view_forward), 1e-9) : pixel_scale;
}

vec3 hair_step(vec3 pos, vec3 tan, float width, float opacity, vec3 color, float t, float seed) {
    // facing the viewer: offset along tangent x view direction (Le Muzic 2012 §5.2.2)
    vec3 to_eye = eye.w > 0.5 ? eye.xyz - pos : eye.xyz;
    vec3 side = cross(tan, to_eye);
    float side_len = length(side);
    side = side_len > 1e-12 * dot(to_eye, to_eye) ? side / side_len : view_right;

    float px = pixel_size(pos);
    float width_px = width / px;
#ifdef LINES
    // a line one pixel wide: its fragments carry the hair's coverage. Aliased, it has
    // one fragment per pixel along its major axis, each standing for
    // length / max(|dx|, |dy|) of it.
    float cover = width_px;
    if (line_stretch) {
        vec4 a_clip = view_proj * vec4(pos, 1.0);
        vec4 b_clip = view_proj * vec4(pos + tan * px, 1.0);
        vec2 d = (b_clip.xy / b_clip.w - a_clip.xy / a_clip.w) * viewport;
        float len = length(d);
        cover *= len > 1e-9 ? len / max(abs(d.x), abs(d.y)) : 1.0;
    }
    opacity *= min(cover, 1.0);
    vec3 offset = vec3(0.0);
#else
    // at least one pixel wide on screen; the lost coverage goes into alpha
    float drawn = width;
    if (width_px < 1.0) {
        opacity *= width_px;
        drawn = px;
    }
    vec3 offset = side * (0.5 * drawn);
#endif

    gs_out.tangent = tan;
    gs_out.side = side;
    gs_out.color = color;
    gs_out.opacity = opacity;
    gs_out.t = t;
    gs_out.seed = seed;
    gs_out.width = width;
    gs_out.shade = vec3(0.0);
#ifdef SHADE
    vec3 E = normalize(to_eye);
    vec3 N = normalize(cross(side, tan));  // faces the eye
    if (dot(N, E) < 0.0) N = -N;
    // across a ribbon v^2 averages 1/3
    gs_out.shade = hair_radiance(pos, tan, N, E, color, t, seed, width, 1.0 / 3.0);
#endif
    return offset;
}
