// The light passes of the deep opacity maps (Yuksel & Keyser 2008). DEPTH: the nearest
// hair depth per texel (blended with MIN). Otherwise: the hair's opacity, added to the
// layer its depth falls in behind that nearest depth.
#ifdef DEPTH
out vec4 nearest;

void main() {
    nearest = vec4(gl_FragCoord.z);
}
#else
uniform sampler2D dom_depth;
uniform float layer_depth;
out vec4 layers;

void main() {
    float first = texelFetch(dom_depth, ivec2(gl_FragCoord.xy), 0).r;
    int k = clamp(int(floor((gl_FragCoord.z - first) / layer_depth)), 0, 3);
    layers = vec4(equal(ivec4(k), ivec4(0, 1, 2, 3))) * clamp(fs_in.opacity, 0.0, 1.0);
}
#endif
