// Lights and the key light's shadows, shared by the hair models and the skin.
// Colours are linear RGB; directions are unit world vectors towards the light.
#define MAX_LIGHTS 8
#define PI 3.14159265358979
uniform int n_lights;
uniform vec3 light_dir[MAX_LIGHTS];
uniform vec3 light_radiance[MAX_LIGHTS];
uniform vec3 ambient;

// Shadows of light 0, the key: deep opacity maps (Yuksel & Keyser 2008) for the hair
// and a plain shadow map for the skin, both rendered from the light (orthographic, so
// light depth is linear in metres).
uniform bool shadows;
uniform mat4 light_view_proj;       // world -> light clip space
uniform sampler2D dom_depth;        // depth of the nearest hair per texel, 0 .. 1
uniform sampler2D dom_layers;       // hair opacity in 4 layers behind it
uniform sampler2D skin_depth;       // the skin's depth (NEAREST, no comparison)
uniform int skin_soft;              // skin receivers' filter radius, texels
uniform float layer_depth;          // one layer's thickness, light depth units
uniform float depth_per_metre;      // light depth units per metre
uniform float light_texel;          // world size of a shadow-map texel, metres
uniform float shadow_density;       // κ of exp(-κ · opacity)

// Hair opacity in front of light depth z at texel q: layer k holds what lies between
// first + kΔ and first + (k+1)Δ (the last layer also everything beyond), counted
// linearly across its thickness.
float dom_opacity(ivec2 q, float z) {
    float first = texelFetch(dom_depth, q, 0).r;
    vec4 layers = texelFetch(dom_layers, q, 0);
    float x = (z - first) / layer_depth;
    return dot(layers, clamp(vec4(x) - vec4(0.0, 1.0, 2.0, 3.0), 0.0, 1.0));
}

// Share of the skin's shadow test passed over a box (2r + 1) texels wide around st
// (texel centres at whole st): each texel's test weighted by its overlap with the box,
// so r = 0 is the 2x2 bilinear percentage-closer filter. Where the box's corners and
// centre agree the answer is theirs: the full sum runs at shadow edges only.
float skin_lit(vec2 st, float z, int r) {
    ivec2 hi = textureSize(skin_depth, 0) - 1;
    ivec2 q = ivec2(floor(st));
    vec2 f = st - vec2(q);
    if (r > 0) {
        float c = step(z, texelFetch(skin_depth, clamp(q, ivec2(0), hi), 0).r);
        float corners = step(z, texelFetch(skin_depth, clamp(q + ivec2(-r, -r), ivec2(0), hi), 0).r)
                      + step(z, texelFetch(skin_depth, clamp(q + ivec2(r + 1, -r), ivec2(0), hi), 0).r)
                      + step(z, texelFetch(skin_depth, clamp(q + ivec2(-r, r + 1), ivec2(0), hi), 0).r)
                      + step(z, texelFetch(skin_depth, clamp(q + ivec2(r + 1, r + 1), ivec2(0), hi), 0).r);
        if (corners == 4.0 * c) return c;
    }
    float sum = 0.0;
    for (int j = -r; j <= r + 1; ++j) {
        float wy = j == -r ? 1.0 - f.y : (j == r + 1 ? f.y : 1.0);
        for (int i = -r; i <= r + 1; ++i) {
            float wx = i == -r ? 1.0 - f.x : (i == r + 1 ? f.x : 1.0);
            sum += wx * wy * step(z, texelFetch(skin_depth, clamp(q + ivec2(i, j), ivec2(0), hi), 0).r);
        }
    }
    float width = float(2 * r + 1);
    return sum / (width * width);
}

// Share of the key light reaching world point p. The lookup moves `lift` metres (the
// receiver's own thickness) plus 1.5 texels towards the light: no self-shadowing. The
// skin's shadow is filtered over 2·soft + 1 texels (skin_lit).
float key_light_visibility(vec3 p, float lift, int soft) {
    if (!shadows) return 1.0;
    vec3 s = (light_view_proj * vec4(p, 1.0)).xyz * 0.5 + 0.5;
    if (any(lessThan(s.xy, vec2(0.0))) || any(greaterThan(s.xy, vec2(1.0)))) return 1.0;
    float z = s.z - (lift + 1.5 * light_texel) * depth_per_metre;
    // bilinear over the 4 nearest texels, each against its own first depth
    ivec2 size = textureSize(dom_depth, 0);
    vec2 st = s.xy * vec2(size) - 0.5;
    vec2 f = fract(st);
    ivec2 q = ivec2(floor(st));
    ivec2 hi = size - 1;
    float o00 = dom_opacity(clamp(q, ivec2(0), hi), z);
    float o10 = dom_opacity(clamp(q + ivec2(1, 0), ivec2(0), hi), z);
    float o01 = dom_opacity(clamp(q + ivec2(0, 1), ivec2(0), hi), z);
    float o11 = dom_opacity(clamp(q + ivec2(1, 1), ivec2(0), hi), z);
    float opacity = mix(mix(o00, o10, f.x), mix(o01, o11, f.x), f.y);
    return skin_lit(st, z, soft) * exp(-shadow_density * opacity);
}
