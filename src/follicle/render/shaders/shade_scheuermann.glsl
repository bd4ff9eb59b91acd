// Scheuermann 2004 (Almeida 2014 §3.3.1, Alg. 5-6): two highlights from tangents shifted along
// the ribbon normal, the primary (white) lobe tilted towards the root and the secondary
// (tinted by the hair colour) towards the tip, like Marschner's R and TRT. Noise along
// each strand jitters both shifts and masks the secondary highlight (Alg. 6 lines 13
// and 18: a noise texture there, procedural noise here). Diffuse is Alg. 6's
// max(0, 0.75 N.L + 0.25) on the ribbon normal.
uniform float p_diffuse;
uniform float p_specular;
uniform float p_shininess;
uniform vec3 p_specular_color;
uniform float p_specular2;
uniform float p_shininess2;
uniform float p_shift;
uniform float p_shift2;
uniform float p_specular_tint;
uniform float p_shift_noise;
uniform float p_sparkle;
uniform float p_noise_frequency;

// Alg. 6 lines 19-21: sin(T, H)^p, faded out as T turns away from H
float strand_specular(vec3 T, vec3 H, float p) {
    float th = dot(T, H);
    return smoothstep(-1.0, 0.0, th) * pow(sqrt(max(0.0, 1.0 - th * th)), p);
}

vec3 hair_shade(vec3 P, vec3 T, vec3 N, vec3 E, vec3 base, float t, float seed, float key) {
    float x = t * p_noise_frequency;
    float jitter = p_shift_noise * (strand_noise(seed, x) - 0.5);
    float mask = mix(1.0, strand_noise(fract(seed + 0.5), 2.3 * x + 0.37), p_sparkle);
    // a positive shift tilts the tangent towards N, moving the lobe towards the root
    vec3 T1 = normalize(T + (p_shift + jitter) * N);
    vec3 T2 = normalize(T + (p_shift2 + jitter) * N);
    vec3 primary = p_specular * p_specular_color * tinted(base, p_specular_tint);
    vec3 diffuse = vec3(0.0);
    vec3 specular = vec3(0.0);
    for (int i = 0; i < n_lights; ++i) {
        vec3 L = light_dir[i];
        vec3 radiance = light_radiance[i] * (i == 0 ? key : 1.0);
        vec3 H = normalize(L + E);
        diffuse += radiance * max(0.0, 0.75 * dot(N, L) + 0.25);
        specular += radiance * (primary * strand_specular(T1, H, p_shininess)
                                + p_specular2 * mask * base * strand_specular(T2, H, p_shininess2));
    }
    return base * (ambient + p_diffuse * diffuse) + specular;
}
