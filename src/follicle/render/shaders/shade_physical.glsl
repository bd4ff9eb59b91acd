// Physically based hair in the real-time forms of Karis 2016 ("Physically Based Hair
// Shading in Unreal"), on Marschner et al. 2003's lobes with Chiang et al. 2016's
// absorption, so that it approaches Mitsuba's hair BSDF (the reference) under the same
// lights. Per light: Σ_p M_p A_p N_p times the irradiance π·radiance (a Lambertian of
// albedo ρ under this light is ρ·radiance·cos), p = R, TT, TRT:
//   M_p  a Gaussian in sin θi + sin θr (normalised over cos θi dθi) of width β_p around
//        the cuticle tilt's shift: R β at -2α, TT β/2 at α, TRT 2β at 4α; β from the
//        roughness as Mitsuba maps it (Chiang 2016 §4.1);
//   N_p  Karis's fits: R cos(φ/2)/4, TT exp(-3.65 cos φ - 3.98), TRT exp(17 cos φ - 16.78);
//   A_p  Schlick Fresnel and, for TT and TRT, the transmittance exp(-σa·l) over the
//        chords l inside the fibre (radius 1: TT 2 cos γt / cos θt at Karis's h(φ), TRT
//        twice that at h = √3/2), σa = k (ln C)² from the hair colour C (Chiang 2016
//        §4.2, k = p_absorption, the mapping Mitsuba's σa comes from).
// Multiple scattering (the soft look): Karis 2016's scatter term, C times a mix of a
// wrapped lighting on the normal facing the eye and 1 - |T·L| (scaled by 3/4: under
// radiance 1 from every side white hair returns 1, as its ambient term), its key light reaching
// deeper through light hair than dark: through the deep opacity maps' visibility v,
// v^(1 - C) per channel (Zinke et al. 2008's forward scattering attenuation a_f^n with
// the colour as the albedo a_f, simplified). The lights without shadows (all but the
// key) would shine TT through the head and the hair in front of a strand: their TT is
// scaled by p_backlit (Karis 2016's Backlit). Light hair is translucent: a fibre lets the
// share p_clear exp(-p_chord σa) (TT at normal incidence, options.see_through_fit) of
// what is behind it through, times p_translucency; its opacity is scaled by 1 - share
// (render.frame.hair_vertices), its single scattering divided by it (see the end).
uniform float p_roughness;
uniform float p_cuticle_tilt;  // radians
uniform float p_eta;
uniform float p_r;
uniform float p_tt;
uniform float p_trt;
uniform float p_scatter;
uniform float p_backlit;       // TT share of the lights without shadows
uniform float p_absorption;    // k of σa = k (ln C)^2
uniform float p_translucency;  // share of TT's see-through kept
uniform float p_clear;         // a fibre's see-through: p_clear exp(-p_chord σa)
uniform float p_chord;

// a TT or TRT lobe whose exponent is below this adds < 1e-6: skipped
#define LOBE_CUT -15.0

// Schlick's Fresnel of the fibre at incidence cosine c
float schlick(float f0, float c) {
    float m = clamp(1.0 - c, 0.0, 1.0);
    float m2 = m * m;
    return f0 + (1.0 - f0) * m2 * m2 * m;
}

vec3 hair_shade(vec3 P, vec3 T, vec3 N, vec3 E, vec3 base, float t, float seed, float key) {
    vec3 colour = clamp(base, vec3(1e-4), vec3(1.0));
    vec3 ln_c = log(colour);
    vec3 sigma = p_absorption * ln_c * ln_c;
    float rho = p_roughness;
    float rho2 = rho * rho;
    float rho10 = rho2 * rho2 * rho;
    rho10 *= rho10;
    float beta = 0.726 * rho + 0.812 * rho2 + 3.7 * rho10 * rho10;  // the R lobe's width
    float g = 0.5 / (beta * beta);  // exp(-g x^2): R; TT 4g (width β/2), TRT g/4 (2β)
    float norm = 1.0 / (beta * sqrt(2.0 * PI));  // R; TT 2 norm, TRT norm / 2
    float f0 = (1.0 - p_eta) / (1.0 + p_eta);
    f0 *= f0;
    float sin_r = clamp(dot(T, E), -1.0, 1.0);
    float cos_r = sqrt(1.0 - sin_r * sin_r);
    vec3 Ep = E - sin_r * T;
    float ep2 = dot(Ep, Ep);
    // the multiple scattering's normal: across the fibre, facing the eye
    vec3 Nf = Ep * inversesqrt(max(ep2, 1e-12));
    // the key light through the hair for multiple scattering: v^(1 - C)
    vec3 key_ms = key < 1.0 ? exp((1.0 - colour) * log(max(key, 1e-6))) : vec3(1.0);
    vec3 rgb = base * ambient;  // the ambient and multiple scattering: the hair volume's
    vec3 own = vec3(0.0);       // single scattering: the fibre's own
    for (int i = 0; i < n_lights; ++i) {
        vec3 L = light_dir[i];
        float sin_i = clamp(dot(T, L), -1.0, 1.0);
        float cos_i = sqrt(1.0 - sin_i * sin_i);
        // cos θd, θd = (θr - θi) / 2
        float cos_d = max(sqrt(max(0.5 + 0.5 * (cos_i * cos_r + sin_i * sin_r), 0.0)), 0.2);
        vec3 Lp = L - sin_i * T;
        float cos_phi = clamp(dot(Lp, Ep) * inversesqrt(max(dot(Lp, Lp) * ep2, 1e-12)),
                              -1.0, 1.0);
        float cos_half = sqrt(0.5 + 0.5 * cos_phi);
        float x = sin_i + sin_r;
        // inside the fibre: the refracted inclination and 1 / η', the 2D (Bravais) index
        float sin_d2 = 1.0 - cos_d * cos_d;
        float cos_t = sqrt(1.0 - sin_d2 / (p_eta * p_eta));
        float a = cos_d / sqrt(p_eta * p_eta - sin_d2);

        float xr = x + 2.0 * p_cuticle_tilt;
        float fr = schlick(f0, sqrt(clamp(0.5 + 0.5 * dot(L, E), 0.0, 1.0)));
        vec3 single = vec3(p_r * norm * exp(-g * xr * xr) * 0.25 * cos_half * fr);
        float xt = x - p_cuticle_tilt;
        float e_tt = -4.0 * g * xt * xt - 3.65 * cos_phi - 3.98;
        float tt_share = i == 0 ? p_tt : p_tt * p_backlit;
        if (e_tt > LOBE_CUT && tt_share > 0.0) {
            float h = cos_half * (1.0 + a * (0.6 - 0.8 * cos_phi));  // Karis's h(φ)
            float f_tt = schlick(f0, cos_d * sqrt(max(1.0 - h * h, 0.0)));
            float w = tt_share * 2.0 * norm * (1.0 - f_tt) * (1.0 - f_tt);
            float l_tt = 2.0 * sqrt(max(1.0 - h * h * a * a, 0.0)) / cos_t;
            single += w * exp(e_tt - sigma * l_tt);
        }
        xt = x - 4.0 * p_cuticle_tilt;
        float e_trt = -0.25 * g * xt * xt + 17.0 * cos_phi - 16.78;
        if (e_trt > LOBE_CUT && p_trt > 0.0) {
            float f_trt = schlick(f0, 0.5 * cos_d);
            float w = p_trt * 0.5 * norm * (1.0 - f_trt) * (1.0 - f_trt) * f_trt;
            float l_trt = 4.0 * sqrt(1.0 - 0.75 * a * a) / cos_t;  // h = √3/2
            single += w * exp(e_trt - sigma * l_trt);
        }
        float wrap = clamp((dot(Nf, L) + 1.0) * 0.25, 0.0, 1.0);
        float scatter = 0.75 * p_scatter * mix(wrap, 1.0 - abs(sin_i), 0.33);
        own += light_radiance[i] * PI * single * (i == 0 ? key : 1.0);
        rgb += light_radiance[i] * colour * scatter * (i == 0 ? key_ms : vec3(1.0));
    }
    // the fibre lets this share of what is behind it through (options.see_through): its
    // opacity is scaled by 1 - share (render.frame.hair_vertices), so its own light is
    // divided by 1 - share; the volume's is blended as is, the hair behind showing
    // through adding the rest of it. That hair is filtered by the fibre's colour (d per
    // channel) where the blend lets the grey share through: the volume's light stands in
    vec3 d = p_translucency * p_clear * exp(-p_chord * sigma);
    float share = dot(d, vec3(0.2126, 0.7152, 0.0722));
    float keep = 1.0 / max(1.0 - share, 1e-3);
    return rgb * max(1.0 + (d - share) * keep, 0.0) + own * keep;
}
