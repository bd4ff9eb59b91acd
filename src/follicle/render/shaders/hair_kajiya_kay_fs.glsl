#version 330 core
// Kajiya-Kay hair shading (001 §3.3.1 eq. 3.8-3.9, 002 §5.2.3 and Listing A.2) in
// linear RGB, with a second tinted, shifted highlight (Scheuermann 2004, 001 §3.3.1)
// and a root-darkening occlusion term.
#define MAX_LIGHTS 8

in GS_OUT {
    vec3 position;
    vec3 tangent;
    vec3 side;
    vec3 color;
    float opacity;
    float v;
    float t;
} fs_in;

out vec4 frag_color;

uniform vec3 eye;
uniform int n_lights;
uniform vec3 light_dir[MAX_LIGHTS];       // unit, towards the light, world space
uniform vec3 light_radiance[MAX_LIGHTS];  // linear RGB
uniform vec3 ambient;

uniform float k_diffuse;
uniform float k_specular;
uniform float shininess;
uniform vec3 specular_color;
uniform float k_specular2;      // secondary (TRT-like) highlight, tinted by the hair colour
uniform float shininess2;
uniform float shift;            // primary highlight tangent shift (towards the root: < 0)
uniform float shift2;           // secondary highlight tangent shift
uniform float root_occlusion;   // 0: none .. 1: black roots
uniform float roundness;        // darkening towards the ribbon edges (fake cylinder)

// sin and cos of the angles between tangent and light (eq. 3.8) and the
// Kajiya-Kay specular cone term (eq. 3.9): maximal when the eye lies on the cone of
// mirror directions around T, i.e. cos(theta_E) = -cos(theta_L) with E towards the
// eye (Listing A.2 writes it acos(-T.V)); 001 eq. 3.9 uses e from the eye to the hair.
float kk_specular(vec3 T, vec3 L, vec3 E, float p) {
    float tl = dot(T, L);
    float te = dot(T, E);
    float c = sqrt(max(0.0, 1.0 - tl * tl)) * sqrt(max(0.0, 1.0 - te * te)) - tl * te;
    return pow(max(c, 0.0), p);
}

void main() {
    vec3 T = normalize(fs_in.tangent);
    vec3 E = normalize(eye - fs_in.position);
    // the ribbon stands in for a cylinder: its normal turns across the width (v)
    vec3 N0 = normalize(cross(fs_in.side, T));
    if (dot(N0, E) < 0.0) N0 = -N0;
    float v = clamp(fs_in.v, -1.0, 1.0);
    vec3 N = normalize(fs_in.side * v + N0 * sqrt(max(0.0, 1.0 - v * v)));
    vec3 T1 = normalize(T + shift * N);
    vec3 T2 = normalize(T + shift2 * N);

    vec3 base = fs_in.color;
    vec3 diffuse = vec3(0.0);
    vec3 specular = vec3(0.0);
    for (int i = 0; i < n_lights; ++i) {
        vec3 L = light_dir[i];
        float tl = dot(T, L);
        float kd = sqrt(max(0.0, 1.0 - tl * tl));  // eq. 3.8: sin(T, L)
        diffuse += light_radiance[i] * kd;
        specular += light_radiance[i] * (k_specular * specular_color * kk_specular(T1, L, E, shininess)
                                         + k_specular2 * base * kk_specular(T2, L, E, shininess2));
    }
    float occlusion = 1.0 - root_occlusion * pow(1.0 - clamp(fs_in.t, 0.0, 1.0), 1.5);
    float round_shade = 1.0 - roundness * v * v;
    vec3 rgb = (base * (ambient + k_diffuse * diffuse) + specular) * occlusion * round_shade;
    frag_color = vec4(rgb, clamp(fs_in.opacity, 0.0, 1.0));
}
