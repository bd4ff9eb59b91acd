#version 330 core
// Hair control points (Catmull-Rom vertices), passed through to the geometry shader.
in vec3 in_position;
in float in_width;     // diameter, metres
in vec3 in_color;      // linear RGB
in float in_opacity;
in float in_t;         // vertex index / (n - 1) along its curve: 0 root, 1 tip

out VS_OUT {
    vec3 position;
    float width;
    vec3 color;
    float opacity;
    float t;
} vs_out;

void main() {
    vs_out.position = in_position;
    vs_out.width = in_width;
    vs_out.color = in_color;
    vs_out.opacity = in_opacity;
    vs_out.t = in_t;
    gl_Position = vec4(in_position, 1.0);
}
