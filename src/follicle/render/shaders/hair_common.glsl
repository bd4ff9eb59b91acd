// What every hair shading model gets: per-strand noise, and the prototype it implements.

// Integer hash (a "lowbias32" mix) to [0, 1).
float hash01(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return float(x) * (1.0 / 4294967296.0);
}

// Smooth value noise along a strand: x in cycles, seed in [0, 1) picks the strand.
float strand_noise(float seed, float x) {
    float i = floor(x);
    float f = x - i;
    uint base = uint(seed * 16777216.0) * 1024u + uint(int(i) & 1023);
    return mix(hash01(base), hash01(base + 1u), f * f * (3.0 - 2.0 * f));
}

// A highlight colour towards the hair's hue by `tint` (0: white .. 1: the hue at full
// brightness): the physical models' lobes that enter the fibre (Marschner's TRT) carry
// its colour, so dark hair's sheen stays brown instead of turning grey at grazing angles.
vec3 tinted(vec3 base, float tint) {
    vec3 hue = base / max(max(base.r, base.g), max(base.b, 1e-6));
    return mix(vec3(1.0), hue, tint);
}

// Radiance leaving hair point P towards the eye (E, unit). T: unit tangent, root to tip;
// N: unit ribbon normal facing the eye (turned across a wide ribbon like a cylinder's);
// base: hair colour; t: 0 at the root .. 1 at the tip; seed: per strand;
// key: share of light 0 reaching P (shadows).
vec3 hair_shade(vec3 P, vec3 T, vec3 N, vec3 E, vec3 base, float t, float seed, float key);
