#version 330 core
// 002 §5.2.1-5.2.2: smooth each segment with a uniform Catmull-Rom spline in the
// geometry shader (lines_adjacency gives the neighbours P0 and P3 of segment P1-P2)
// and expand it into a camera-facing triangle strip.
#define MAX_SUBDIVISIONS 16
layout(lines_adjacency) in;
layout(triangle_strip, max_vertices = 34) out;  // 2 * (MAX_SUBDIVISIONS + 1)

in VS_OUT {
    vec3 position;
    float width;
    vec3 color;
    float opacity;
    float t;
} gs_in[];

out GS_OUT {
    vec3 position;   // world
    vec3 tangent;    // world, unit
    vec3 side;       // world, unit, across the ribbon
    vec3 color;
    float opacity;
    float v;         // -1 .. 1 across the ribbon
    float t;         // 0 root .. 1 tip
} gs_out;

uniform mat4 view_proj;
uniform vec3 eye;
uniform vec3 cam_forward;
uniform vec3 cam_right;
uniform int subdivisions;
uniform float pixel_scale;   // world size of one pixel per metre of view depth
uniform float min_width_px;  // thinner ribbons are widened to this and faded by coverage

void main() {
    vec3 p0 = gs_in[0].position;
    vec3 p1 = gs_in[1].position;
    vec3 p2 = gs_in[2].position;
    vec3 p3 = gs_in[3].position;
    // uniform Catmull-Rom in power form (002 Listing 5.6): P(u) = a u^3 + b u^2 + c u + p1
    vec3 a = -p0 + 3.0 * p1 - 3.0 * p2 + p3;
    vec3 b = 2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3;
    vec3 c = p2 - p0;
    vec3 chord = p2 - p1;
    int n = clamp(subdivisions, 1, MAX_SUBDIVISIONS);
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
        tan = dot(tan, tan) > 0.0 ? normalize(tan) : cam_forward;

        float width = mix(gs_in[1].width, gs_in[2].width, u);
        float opacity = mix(gs_in[1].opacity, gs_in[2].opacity, u);
        vec3 color = mix(gs_in[1].color, gs_in[2].color, u);
        float t = mix(gs_in[1].t, gs_in[2].t, u);

        // camera-facing: offset along tangent x eye direction (002 §5.2.2)
        vec3 to_eye = eye - pos;
        vec3 side = cross(tan, to_eye);
        float side_len = length(side);
        side = side_len > 1e-12 * dot(to_eye, to_eye) ? side / side_len : cam_right;

        // at least min_width_px on screen; the lost coverage goes into alpha
        float pixel = pixel_scale * max(dot(pos - eye, cam_forward), 1e-9);
        float width_px = width / pixel;
        if (width_px < min_width_px) {
            opacity *= width_px / min_width_px;
            width = min_width_px * pixel;
        }
        vec3 offset = side * (0.5 * width);

        gs_out.tangent = tan;
        gs_out.side = side;
        gs_out.color = color;
        gs_out.opacity = opacity;
        gs_out.t = t;

        gs_out.position = pos + offset;
        gs_out.v = 1.0;
        gl_Position = view_proj * vec4(gs_out.position, 1.0);
        EmitVertex();

        gs_out.position = pos - offset;
        gs_out.v = -1.0;
        gl_Position = view_proj * vec4(gs_out.position, 1.0);
        EmitVertex();
    }
    EndPrimitive();
}
