// One triangle covering the screen, from gl_VertexID alone.
out float v_y;  // 0 at the bottom edge, 1 at the top
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    v_y = p.y;
    gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);
}
