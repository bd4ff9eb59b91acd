// What the hair geometry shader emits per vertex: declared `out ... gs_out` there and
// `in ... fs_in` in the hair fragment shaders (VARYING and VARYING_NAME are defined
// when the program is assembled).
VARYING GS_OUT {
    vec3 position;   // world
    vec3 tangent;    // world, unit, root to tip
    vec3 side;       // world, unit, across the ribbon
    vec3 color;      // linear RGB
    float opacity;   // opacity x the coverage of a widened ribbon
    float v;         // -1 .. 1 across the ribbon
    float t;         // 0 root .. 1 tip
    float seed;      // per strand, [0, 1)
    float width;     // true diameter, metres
    vec3 shade;      // radiance shaded in the geometry shader (SHADE)
} VARYING_NAME;
