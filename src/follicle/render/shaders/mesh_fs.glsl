// Skin: Lambert with a wrap-around term under the same lights as the hair, the key
// light shadowed by the hair (deep opacity maps) and by the skin itself, its own
// shadow's edges filtered [render] skin_softness wide.
in vec3 v_position;
in vec3 v_normal;
in vec3 v_color;  // the skin's colour here, tinted under the hair
out vec4 frag_color;
uniform vec4 eye;
uniform float wrap;  // soft wrap-around lighting, a cheap stand-in for subsurface scattering

void main() {
    vec3 N = normalize(v_normal);
    vec3 E = normalize(eye.xyz - v_position);
    if (dot(N, E) < 0.0) N = -N;  // two-sided
    // looked up a little off the surface (normal offset) and, for the filter's width,
    // nearer the light as the surface slopes away from it: no shadow acne
    float c = max(abs(dot(N, light_dir[0])), 0.2);
    float slope = float(skin_soft + 1) * light_texel * sqrt(1.0 - c * c) / c;
    float key = key_light_visibility(v_position + N * (2.0 * light_texel), slope, skin_soft);
    vec3 light = ambient;
    for (int i = 0; i < n_lights; ++i) {
        float nl = (dot(N, light_dir[i]) + wrap) / (1.0 + wrap);
        light += light_radiance[i] * (i == 0 ? key : 1.0) * max(nl, 0.0);
    }
    frag_color = vec4(v_color * light, 1.0);
}
