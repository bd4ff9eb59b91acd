#version 330 core
// Skin: Lambert under the same lights as the hair, plus ambient, in linear RGB.
#define MAX_LIGHTS 8
in vec3 v_position;
in vec3 v_normal;
out vec4 frag_color;
uniform vec3 eye;
uniform int n_lights;
uniform vec3 light_dir[MAX_LIGHTS];
uniform vec3 light_radiance[MAX_LIGHTS];
uniform vec3 ambient;
uniform vec3 skin_color;
uniform float wrap;  // soft wrap-around lighting, a cheap stand-in for subsurface scattering

void main() {
    vec3 N = normalize(v_normal);
    vec3 E = normalize(eye - v_position);
    if (dot(N, E) < 0.0) N = -N;  // two-sided
    vec3 light = ambient;
    for (int i = 0; i < n_lights; ++i) {
        float nl = (dot(N, light_dir[i]) + wrap) / (1.0 + wrap);
        light += light_radiance[i] * max(nl, 0.0);
    }
    frag_color = vec4(skin_color * light, 1.0);
}
