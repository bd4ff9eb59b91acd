in vec3 in_position;
in vec3 in_normal;
in vec3 in_color;  // linear RGB: the skin, tinted under the hair (scalp.py)
out vec3 v_position;
out vec3 v_normal;
out vec3 v_color;
uniform mat4 view_proj;
void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_color = in_color;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
