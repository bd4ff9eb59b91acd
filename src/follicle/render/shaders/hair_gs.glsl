// Le Muzic 2012 §5.2.1-5.2.2: smooth each segment with a uniform Catmull-Rom spline in the
// geometry shader (lines_adjacency gives the neighbours P0 and P3 of segment P1-P2)
// and expand it into a triangle strip facing the viewer: the camera (perspective) or
// a light (orthographic). With LINES, for hair thinner than a pixel, emit a one-pixel
// line strip instead, its opacity scaled by the share of the pixels the hair covers
// (half the primitives of a ribbon: llvmpipe is bound by the primitives it sets up).
// A segment gets as many steps as its on-screen length and bend need, at most
// `subdivisions`. What each step gets (its side, coverage and, with SHADE, its shade)
// is hair_step.glsl's.
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

uniform int subdivisions;    // most Catmull-Rom steps per segment
uniform float max_step_px;   // longest step in pixels (shading is interpolated along it)

const float CHORD_TOLERANCE_PX = 0.25;  // largest gap between spline and steps, pixels

void main() {
    vec3 p0 = gs_in[0].position;
    vec3 p1 = gs_in[1].position;
    vec3 p2 = gs_in[2].position;
    vec3 p3 = gs_in[3].position;
    // uniform Catmull-Rom in power form (Le Muzic 2012 Listing 5.6): P(u) = p1 + (a u^3 + b u^2 + c u) / 2
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

        vec3 offset = hair_step(pos, tan, mix(gs_in[1].width, gs_in[2].width, u),
                                mix(gs_in[1].opacity, gs_in[2].opacity, u),
                                mix(gs_in[1].color, gs_in[2].color, u),
                                mix(gs_in[1].t, gs_in[2].t, u), gs_in[1].seed);
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
