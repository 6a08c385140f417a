// The environment map's lookup at reflector k's pixels (refsoft/envmap/method.py
// ``reflected_rays``, refsoft/envmap/cube.py ``lookup``), in REAL: the reflected direction
// r = I - 2 (N . I) N from the eye-relative position and normal the raster interpolated, its
// face (major axis, ties z over y over x; the positive face when r_a's sign bit is clear) and
// nearest texel; the texel's colour and object id for the composite, the face and texel as
// outputs. EXACT 1: every dot product and division written out in refsoft's order. EXACT 0 (the
// plain variant): GLSL's normalize and dot, no precise, and the texel found by GL's own cube-map
// sampling (nearest) of a texture holding each texel's index.
#include "common.glsl"

#if EXACT
#define PRECISE precise
#else
#define PRECISE
#endif
#if DOUBLE
#define VEC3 dvec3
#else
#define VEC3 vec3
#endif

layout(std430, binding = 0) readonly buffer ViewId { int view_id[]; };
layout(std430, binding = 1) readonly buffer Pos { REAL pos[]; };        // (H, W, 3) P - eye
layout(std430, binding = 2) readonly buffer Nrm { REAL nrm[]; };        // (H, W, 3) unit normal
layout(std430, binding = 3) readonly buffer CubeId { int cube_id[]; };  // (6, R, R)
layout(std430, binding = 4) readonly buffer CubeColour { float cube_colour[]; };  // (6, R, R, 3)
layout(std430, binding = 5) readonly buffer Dir { double view_dir[]; }; // orthographic: (3,)
layout(std430, binding = 6) writeonly buffer OutC { float out_c[]; };   // (H, W, 3)
layout(std430, binding = 7) writeonly buffer OutId { int out_id[]; };   // (H, W)
layout(std430, binding = 8) buffer OutFace { int out_face[]; };         // (H, W), -1 elsewhere
layout(std430, binding = 9) buffer OutTexel { int out_texel[]; };       // (H, W, 2), -1 elsewhere

#if !EXACT
uniform isamplerCube texel_index;   // (face R + row) R + col per texel
#endif

uniform int n;
uniform int reflector;
uniform int resolution;
uniform bool orthographic;

void main() {
    uint pu = gid();
    if (pu >= uint(n)) return;
    int p = int(pu);
    for (int ch = 0; ch < 3; ch++) out_c[3 * p + ch] = 0.0;
    out_id[p] = 0;
    if (view_id[p] != reflector) return;
    PRECISE REAL P[3], N[3], I[3], r[3];
    for (int ch = 0; ch < 3; ch++) { P[ch] = pos[3 * p + ch]; N[ch] = nrm[3 * p + ch]; }
    if (orthographic) {
        for (int ch = 0; ch < 3; ch++) I[ch] = REAL(view_dir[ch]);
    } else {
#if EXACT
        precise REAL len = sqrt((P[0] * P[0] + P[1] * P[1]) + P[2] * P[2]);
        for (int ch = 0; ch < 3; ch++) I[ch] = len > REAL(0.0) ? P[ch] / len : REAL(0.0);
#else
        VEC3 i3 = normalize(VEC3(P[0], P[1], P[2]));
        for (int ch = 0; ch < 3; ch++) I[ch] = i3[ch];
#endif
    }
#if EXACT
    precise REAL k = REAL(2.0) * ((N[0] * I[0] + N[1] * I[1]) + N[2] * I[2]);
#else
    REAL k = REAL(2.0) * dot(VEC3(N[0], N[1], N[2]), VEC3(I[0], I[1], I[2]));
#endif
    for (int ch = 0; ch < 3; ch++) r[ch] = I[ch] - k * N[ch];
#if EXACT
    REAL ax = abs(r[0]), ay = abs(r[1]), az = abs(r[2]);
    int axis = (az >= ay && az >= ax) ? 2 : (ay >= ax ? 1 : 0);
    REAL x = r[0], y = r[1], z = r[2];
    // the sign bit, as NumPy's signbit: -0.0 counts as negative
#if DOUBLE
    bool negative = (unpackDouble2x32(r[axis]).y & 0x80000000u) != 0u;
#else
    bool negative = (floatBitsToUint(r[axis]) & 0x80000000u) != 0u;
#endif
    int face = 2 * axis + (negative ? 1 : 0);
    REAL sc, tc, ma;   // GL's cube-map table (spec section 8.13)
    if (face == 0) { sc = -z; tc = -y; ma = x; }
    else if (face == 1) { sc = z; tc = -y; ma = -x; }
    else if (face == 2) { sc = x; tc = z; ma = y; }
    else if (face == 3) { sc = x; tc = -z; ma = -y; }
    else if (face == 4) { sc = x; tc = -y; ma = z; }
    else { sc = -x; tc = -y; ma = -z; }
    precise REAL s = (sc / ma + REAL(1.0)) * REAL(0.5);
    precise REAL t = (tc / ma + REAL(1.0)) * REAL(0.5);
    precise REAL sR = s * REAL(resolution);
    precise REAL tR = t * REAL(resolution);
    int top = resolution - 1;
    int col = int(clamp(floor(sR), REAL(0.0), REAL(top)));
    int row = top - int(clamp(floor(tR), REAL(0.0), REAL(top)));
    int texel = (face * resolution + row) * resolution + col;
#else
    int texel = textureLod(texel_index, vec3(r[0], r[1], r[2]), 0.0).x;
    int face = texel / (resolution * resolution);
    int row = (texel / resolution) % resolution;
    int col = texel % resolution;
#endif
    int id = cube_id[texel];
    for (int ch = 0; ch < 3; ch++) out_c[3 * p + ch] = cube_colour[3 * texel + ch];
    out_id[p] = id;
    out_face[p] = face;
    out_texel[2 * p] = row;
    out_texel[2 * p + 1] = col;
}
