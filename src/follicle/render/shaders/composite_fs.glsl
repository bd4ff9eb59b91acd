// Weighted blended OIT, final step: the hair's average colour Σcαw / Σαw covers the
// opaque layer (background and skin) by 1 - Π(1 - α). With MSAA each sample is
// composited, then the samples are averaged.
#ifdef MSAA
uniform sampler2DMS opaque;
uniform sampler2DMS accum;
uniform sampler2DMS weight;
uniform int samples;
#else
uniform sampler2D opaque;
uniform sampler2D accum;
uniform sampler2D weight;
#endif
out vec4 frag_color;

vec3 composite(ivec2 p, int s) {
    vec3 behind = texelFetch(opaque, p, s).rgb;
    vec4 a = texelFetch(accum, p, s);
    float w = texelFetch(weight, p, s).r;
    vec3 hair = w > 0.0 ? a.rgb / w : vec3(0.0);
    return mix(hair, behind, a.a);
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
#ifdef MSAA
    vec3 sum = vec3(0.0);
    for (int s = 0; s < samples; ++s) sum += composite(p, s);
    frag_color = vec4(sum / float(samples), 1.0);
#else
    frag_color = vec4(composite(p, 0), 1.0);
#endif
}
