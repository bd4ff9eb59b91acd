// The model's radiance with the key light's shadows, a root-darkening occlusion term and
// a darkening towards the ribbon edges (v2: mean of v^2 over the shaded area, v = -1..1
// across the ribbon).
uniform float root_occlusion;
uniform float roundness;

vec3 hair_radiance(vec3 P, vec3 T, vec3 N, vec3 E, vec3 base, float t, float seed,
                   float width, float v2) {
    float key = key_light_visibility(P, width, 0);
    float occlusion = 1.0 - root_occlusion * pow(1.0 - clamp(t, 0.0, 1.0), 1.5);
    return hair_shade(P, T, N, E, base, t, seed, key) * occlusion * (1.0 - roundness * v2);
}
