// Kajiya-Kay (Almeida 2014 §3.3.1 eq. 3.8-3.9; Le Muzic 2012 §5.2.3, Listing A.2): diffuse from the sine of
// the tangent-light angle, specular from the cone of mirror directions around the
// tangent; optionally a second, hair-tinted highlight on a tangent shifted along the
// ribbon normal (specular2 > 0).
uniform float p_diffuse;
uniform float p_specular;
uniform float p_shininess;
uniform vec3 p_specular_color;
uniform float p_specular2;
uniform float p_shininess2;
uniform float p_shift;
uniform float p_shift2;
uniform float p_specular_tint;

// eq. 3.9: cos(θL)cos(θE) + sin(θL)sin(θE) with E towards the eye is greatest when E
// lies on the cone of mirror directions, cos(θE) = -cos(θL) (Listing A.2: acos(-T.V)).
float kk_specular(vec3 T, vec3 L, vec3 E, float p) {
    float tl = dot(T, L);
    float te = dot(T, E);
    float c = sqrt(max(0.0, 1.0 - tl * tl)) * sqrt(max(0.0, 1.0 - te * te)) - tl * te;
    return pow(max(c, 0.0), p);
}

vec3 hair_shade(vec3 P, vec3 T, vec3 N, vec3 E, vec3 base, float t, float seed, float key) {
    vec3 T1 = normalize(T + p_shift * N);
    vec3 T2 = normalize(T + p_shift2 * N);
    vec3 primary = p_specular * p_specular_color * tinted(base, p_specular_tint);
    vec3 diffuse = vec3(0.0);
    vec3 specular = vec3(0.0);
    for (int i = 0; i < n_lights; ++i) {
        vec3 L = light_dir[i];
        vec3 radiance = light_radiance[i] * (i == 0 ? key : 1.0);
        float tl = dot(T, L);
        diffuse += radiance * sqrt(max(0.0, 1.0 - tl * tl));  // eq. 3.8: sin(T, L)
        specular += radiance * (primary * kk_specular(T1, L, E, p_shininess)
                                + p_specular2 * base * kk_specular(T2, L, E, p_shininess2));
    }
    return base * (ambient + p_diffuse * diffuse) + specular;
}
