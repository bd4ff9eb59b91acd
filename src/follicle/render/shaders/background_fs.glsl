in float v_y;
out vec4 frag_color;
uniform vec3 top;     // linear RGB
uniform vec3 bottom;
void main() {
    frag_color = vec4(mix(bottom, top, clamp(v_y, 0.0, 1.0)), 1.0);
}
