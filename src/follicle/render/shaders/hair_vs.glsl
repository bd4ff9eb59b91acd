// Hair control points (Catmull-Rom vertices), passed through to the geometry shader.
in vec3 in_position;
in float in_width;     // diameter, metres
in vec3 in_color;      // linear RGB
in float in_opacity;
in float in_t;         // vertex index / (n - 1) along its curve: 0 root, 1 tip
in float in_seed;      // per strand, in [0, 1): varies noise between strands

out VS_OUT {
    vec3 position;
    float width;
    vec3 color;
    float opacity;
    float t;
    float seed;
} vs_out;

void main() {
    vs_out.position = in_position;
    vs_out.width = in_width;
    vs_out.color = in_color;
    vs_out.opacity = in_opacity;
    vs_out.t = in_t;
    vs_out.seed = in_seed;
    gl_Position = vec4(in_position, 1.0);
}
