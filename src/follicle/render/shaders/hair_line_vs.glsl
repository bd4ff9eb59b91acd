// Hair thinner than a pixel at one step a segment (subdivisions 1): its vertices go to
// the rasteriser as lines without a geometry shader (which llvmpipe runs on one
// thread), each shaded here with the tangent the geometry shader gives a step there,
// (P[i+1] - P[i-1]) / 2 with the curve's ends as their own neighbours (in_tangent):
// the geometry shader's lines, per vertex.
in vec3 in_position;
in vec3 in_tangent;
in float in_width;     // diameter, metres
in vec3 in_color;      // linear RGB
in float in_opacity;
in float in_t;         // vertex index / (n - 1) along its curve: 0 root, 1 tip
in float in_seed;      // per strand, in [0, 1)

void main() {
    vec3 tan = dot(in_tangent, in_tangent) > 0.0 ? normalize(in_tangent) : view_forward;
    hair_step(in_position, tan, in_width, in_opacity, in_color, in_t, in_seed);
    gs_out.position = in_position;
    gs_out.v = 0.0;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
