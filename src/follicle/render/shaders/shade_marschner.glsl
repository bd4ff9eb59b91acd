// Marschner et al. 2003, simplified for real time: lobes R (surface reflection), TT
// (transmission) and TRT (internal reflection), each a longitudinal Gaussian M_p(θh)
// (shifts α, -α/2, -3α/2; widths β, β/2, 2β) times an azimuthal term N_p(φ), over
// cos²θd. N_R = cos(φ/2)/4 · Fresnel; N_TT a Gaussian around φ = π (forward
// scattering); N_TRT constant in φ. The hair colour is an absorption
// σa = -ln(base) per fibre diameter: light crossing a fibre through its centre keeps
// exactly the base colour, TT and TRT are tinted by exp(-σa · path). A sin(T, L)
// diffuse term stands in for multiple scattering.
uniform float p_alpha;     // radians
uniform float p_beta;      // radians
uniform float p_r;
uniform float p_tt;
uniform float p_trt;
uniform float p_tt_width;  // radians
uniform float p_eta;
uniform float p_diffuse;

float gaussian(float width, float x) {
    return exp(-0.5 * x * x / (width * width)) / (width * sqrt(2.0 * PI));
}

// unpolarised Fresnel reflectance of a dielectric at incidence cosine c
float fresnel(float eta, float c) {
    float sin_t2 = (1.0 - c * c) / (eta * eta);
    if (sin_t2 >= 1.0) return 1.0;
    float ct = sqrt(1.0 - sin_t2);
    float rs = (c - eta * ct) / (c + eta * ct);
    float rp = (eta * c - ct) / (eta * c + ct);
    return 0.5 * (rs * rs + rp * rp);
}

vec3 hair_shade(vec3 P, vec3 T, vec3 N, vec3 E, vec3 base, float t, float seed, float key) {
    vec3 sigma = -log(clamp(base, vec3(1e-4), vec3(1.0)));  // per fibre diameter
    float sin_r = clamp(dot(T, E), -1.0, 1.0);
    float theta_r = asin(sin_r);
    vec3 Ep = E - sin_r * T;
    vec3 rgb = base * ambient;
    for (int i = 0; i < n_lights; ++i) {
        vec3 L = light_dir[i];
        vec3 radiance = light_radiance[i] * (i == 0 ? key : 1.0);
        float sin_i = clamp(dot(T, L), -1.0, 1.0);
        float theta_i = asin(sin_i);
        float cos_i = sqrt(1.0 - sin_i * sin_i);
        float theta_h = 0.5 * (theta_i + theta_r);
        float theta_d = 0.5 * (theta_r - theta_i);
        float cos_d = max(cos(theta_d), 0.2);
        // φ: 0 with light and eye on the same side of the fibre, π with the light behind it
        vec3 Lp = L - sin_i * T;
        float cos_phi = dot(Lp, Ep) * inversesqrt(max(dot(Lp, Lp) * dot(Ep, Ep), 1e-12));
        float phi = acos(clamp(cos_phi, -1.0, 1.0));

        float m_r = gaussian(p_beta, theta_h - p_alpha);
        float m_tt = gaussian(0.5 * p_beta, theta_h + 0.5 * p_alpha);
        float m_trt = gaussian(2.0 * p_beta, theta_h + 1.5 * p_alpha);

        // inside the fibre: refracted inclination θt and the 2D (Bravais) index
        float sin_d = sin(theta_d);
        float cos_t = sqrt(1.0 - sin_d * sin_d / (p_eta * p_eta));
        float eta_2d = sqrt(p_eta * p_eta - sin_d * sin_d) / cos_d;
        float f_centre = fresnel(p_eta, cos_d);                 // entering at h = 0
        float n_r = 0.25 * cos(0.5 * phi) * fresnel(p_eta, cos_d * cos(0.5 * phi));
        // TT: through the centre, one diameter / cos θt
        vec3 n_tt = (1.0 - f_centre) * (1.0 - f_centre) * exp(-sigma / cos_t)
                    * gaussian(p_tt_width, PI - phi);
        // TRT: about h = √3/2, where its caustic lies: two chords of cos γt diameters
        float cos_gt = sqrt(1.0 - 0.75 / (eta_2d * eta_2d));
        float f_trt = fresnel(p_eta, 0.5 * cos_d);
        vec3 n_trt = 0.25 * (1.0 - f_trt) * (1.0 - f_trt) * f_trt
                     * exp(-sigma * 2.0 * cos_gt / cos_t);

        vec3 s = (p_r * m_r * n_r + p_tt * m_tt * n_tt + p_trt * m_trt * n_trt) / (cos_d * cos_d);
        rgb += radiance * (s * cos_i + p_diffuse * base * cos_i);
    }
    return rgb;
}
