// Hair colour pass: the geometry shader's shading per step (SHADED, thin hair) or the
// shading per fragment (wide ribbons), blended order-independently (weighted blended OIT,
// McGuire & Bavoil 2013): colour·α·w and α·w are summed, Π(1 - α) multiplied, with
// the blend (ONE, ONE) on colour and (ZERO, ONE_MINUS_SRC_ALPHA) on alpha.
layout(location = 0) out vec4 accum;   // rgb: Σ colour·α·w; a: Π(1 - α)
layout(location = 1) out vec4 weight;  // r: Σ α·w

uniform vec4 eye;
uniform float oit_depth;      // view depth of the nearest hair, metres
uniform float oit_sharpness;  // w = exp(-k (depth - oit_depth) / oit_depth)

void main() {
    float alpha = clamp(fs_in.opacity, 0.0, 1.0);
#ifdef SHADED
    vec3 rgb = fs_in.shade;
#else
    vec3 T = normalize(fs_in.tangent);
    vec3 E = normalize(eye.xyz - fs_in.position);
    // the ribbon stands in for a cylinder: its normal turns across the width (v)
    vec3 N0 = normalize(cross(fs_in.side, T));
    if (dot(N0, E) < 0.0) N0 = -N0;
    float v = clamp(fs_in.v, -1.0, 1.0);
    vec3 N = normalize(fs_in.side * v + N0 * sqrt(max(0.0, 1.0 - v * v)));
    vec3 rgb = hair_radiance(fs_in.position, T, N, E, fs_in.color, fs_in.t, fs_in.seed,
                             fs_in.width, v * v);
#endif
    float depth = 1.0 / gl_FragCoord.w;  // perspective: the view depth
    float w = max(exp(-oit_sharpness * max(depth - oit_depth, 0.0) / oit_depth), 1e-20);
    accum = vec4(rgb * alpha * w, alpha);
    weight = vec4(alpha * w, 0.0, 0.0, 0.0);
}
