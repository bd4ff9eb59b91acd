// 002 §5.2.1-5.2.2: smooth each segment with a uniform Catmull-Rom spline in the
// geometry shader (lines_adjacency gives the neighbours P0 and P3 of segment P1-P2)
// and expand it into a triangle strip facing the viewer: the camera (perspective) or
// a light (orthographic). With LINES, for hair thinner than a pixel, emit a one-pixel
// line strip instead, its opacity scaled by the share of the pixels the hair covers
// (half the primitives of a ribbon: llvmpipe is bound by the primitives it sets up).
// A segment gets as many steps as its on-screen length and bend need, at most
// `subdivisions`. With SHADE the hair is shaded here, once per step, not per fragment.
#define MAX_SUBDIVISIONS 16
layout(lines_adjacency) in;
#ifdef LINES
layout(line_strip, max_vertices = 17) out;  // MAX_SUBDIVISIONS + 1
#else
layout(triangle_strip, max_vertices = 34) out;  // 2 * (MAX_SUBDIVISIONS + 1)
#endif

in VS_OUT {
    vec3 position;
    float width;
    vec3 color;
    float opacity;
    float t;
    float seed;
} gs_in[];


uniform mat4 view_proj;
uniform vec4 eye;            // w = 1: camera position; w = 0: unit direction to the viewer
uniform vec3 view_forward;
uniform vec3 view_right;
uniform float pixel_scale;   // world size of a pixel: per metre of depth (w = 1), or flat
uniform int subdivisions;    // most Catmull-Rom steps per segment
uniform float max_step_px;   // longest step in pixels (shading is interpolated along it)
uniform vec2 viewport;       // pixels
uniform bool line_stretch;   // aliased lines: one fragment per pixel along the major axis

const float CHORD_TOLERANCE_PX = 0.25;  // largest gap between spline and steps, pixels

float pixel_size(vec3 p) {
    return eye.w > 0.5 ? pixel_scale * max(dot(p - eye.xyz, view_forward), 1e-9) : pixel_scale;
}

void main() {
    vec3 p0 = gs_in[0].position;
    vec3 p1 = gs_in[1].position;
    vec3 p2 = gs_in[2].position;
    vec3 p3 = gs_in[3].position;
    // uniform Catmull-Rom in power form (002 Listing 5.6): P(u) = p1 + (a u^3 + b u^2 + c u) / 2
    vec3 a = -p0 + 3.0 * p1 - 3.0 * p2 + p3;
    vec3 b = 2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3;
    vec3 c = p2 - p0;
    vec3 chord = p2 - p1;
    // steps: the chord error of n steps falls as 1/n^2 from its value at n = 1
    vec3 mid = p1 + 0.5 * (((a * 0.5 + b) * 0.5 + c) * 0.5);
    float px_mid = pixel_size(mid);
    float bend = length(mid - 0.5 * (p1 + p2)) / px_mid;
    float steps = max(sqrt(bend / CHORD_TOLERANCE_PX), length(chord) / (px_mid * max_step_px));
    int n = clamp(int(ceil(steps)), 1, min(subdivisions, MAX_SUBDIVISIONS));
    for (int k = 0; k <= n; ++k) {
        float u = float(k) / float(n);
        vec3 pos;
        vec3 tan;
        // the end points use the shared expressions of the neighbouring segments, so
        // consecutive strips meet bit-exactly
        if (k == 0) {
            pos = p1;
            tan = 0.5 * (p2 - p0);
        } else if (k == n) {
            pos = p2;
            tan = 0.5 * (p3 - p1);
        } else {
            pos = p1 + 0.5 * (((a * u + b) * u + c) * u);
            tan = 0.5 * ((3.0 * a * u + 2.0 * b) * u + c);
        }
        if (dot(tan, tan) < 1e-24) tan = chord;
        tan = dot(tan, tan) > 0.0 ? normalize(tan) : view_forward;

        float width = mix(gs_in[1].width, gs_in[2].width, u);
        float opacity = mix(gs_in[1].opacity, gs_in[2].opacity, u);
        vec3 color = mix(gs_in[1].color, gs_in[2].color, u);
        float t = mix(gs_in[1].t, gs_in[2].t, u);

        // facing the viewer: offset along tangent x view direction (002 §5.2.2)
        vec3 to_eye = eye.w > 0.5 ? eye.xyz - pos : eye.xyz;
        vec3 side = cross(tan, to_eye);
        float side_len = length(side);
        side = side_len > 1e-12 * dot(to_eye, to_eye) ? side / side_len : view_right;

        float px = pixel_size(pos);
        float width_px = width / px;
#ifdef LINES
        // a line one pixel wide: its fragments carry the hair's coverage. Aliased, it
        // has one fragment per pixel along its major axis, each standing for
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
        gs_out.seed = gs_in[1].seed;
        gs_out.width = width;
        gs_out.shade = vec3(0.0);
#ifdef SHADE
        vec3 E = normalize(to_eye);
        vec3 N = normalize(cross(side, tan));  // faces the eye
        if (dot(N, E) < 0.0) N = -N;
        // across a ribbon v^2 averages 1/3
        gs_out.shade = hair_radiance(pos, tan, N, E, color, t, gs_in[1].seed, width, 1.0 / 3.0);
#endif
#ifdef LINES
        gs_out.position = pos;
        gs_out.v = 0.0;
        gl_Position = view_proj * vec4(pos, 1.0);
        EmitVertex();
#else
        gs_out.position = pos + offset;
        gs_out.v = 1.0;
        gl_Position = view_proj * vec4(gs_out.position, 1.0);
        EmitVertex();

        gs_out.position = pos - offset;
        gs_out.v = -1.0;
        gl_Position = view_proj * vec4(gs_out.position, 1.0);
        EmitVertex();
#endif
    }
    EndPrimitive();
}
