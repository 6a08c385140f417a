// Attributes of the visible triangle at every pixel (refsoft/raster/_kernels.py
// ``interpolate_pair`` / ``interpolate_rows``), in REAL:
//   MODE 0 (G-buffer): positions relative to the origin and renormalised normals, the mask;
//   MODE 1 (main view): renormalised float32 normals, shaded (spec section 5), object ids;
//   MODE 2 (virtual scene): the same, kept on reflector k's stencil: colour, id, coverage.
#include "common.glsl"
#include "bary.glsl"

layout(binding = 0, r32i) uniform readonly iimage2D index_image;   // clip triangle + 1, 0 none
layout(std430, binding = 5) readonly buffer Faces { int faces[]; };
layout(std430, binding = 6) readonly buffer Positions { double positions[]; };  // (V, 3)
layout(std430, binding = 7) readonly buffer Normals { double normals[]; };      // (V, 3)
layout(std430, binding = 8) readonly buffer Params { double params[]; };        // origin at 18..20
layout(std430, binding = 9) readonly buffer Shading { float shading[]; };       // light, ambient, diffuse, background, colours
layout(std430, binding = 10) readonly buffer FaceObject { int face_object[]; };
layout(std430, binding = 11) readonly buffer Stencil { int view_id[]; };        // main view's object ids (MODE 2)
#if MODE == 0
layout(std430, binding = 12) writeonly buffer OutP { REAL out_p[]; };
layout(std430, binding = 13) writeonly buffer OutN { REAL out_n[]; };
layout(std430, binding = 14) writeonly buffer OutM { int out_mask[]; };
#else
layout(std430, binding = 12) writeonly buffer OutC { float out_c[]; };
layout(std430, binding = 13) writeonly buffer OutId { int out_id[]; };
#endif

uniform int width;
uniform int height;
uniform int reflector;   // MODE 2: k
uniform ivec4 region;    // rows region.x .. region.y - 1, cols region.z .. region.w - 1

void main() {
    uint i = gid();
    int rw = region.w - region.z;
    if (i >= uint((region.y - region.x) * rw)) return;
    int row = region.x + int(i) / rw;
    int col = region.z + int(i) % rw;
    int p = row * width + col;
    int t = imageLoad(index_image, ivec2(col, height - 1 - row)).x - 1;
#if MODE == 0
    if (t < 0) {
        for (int ch = 0; ch < 3; ch++) { out_p[3 * p + ch] = REAL(0.0); out_n[3 * p + ch] = REAL(0.0); }
        out_mask[p] = 0;
        return;
    }
    REAL b0, b1, b2;
    barycentrics(t, row, col, height, b0, b1, b2);
    int f = tri_info[t].x;
    int v0 = faces[3 * f], v1 = faces[3 * f + 1], v2 = faces[3 * f + 2];
    for (int ch = 0; ch < 3; ch++) {
        precise REAL a0 = REAL(positions[3 * v0 + ch] - params[18 + ch]);
        precise REAL a1 = REAL(positions[3 * v1 + ch] - params[18 + ch]);
        precise REAL a2 = REAL(positions[3 * v2 + ch] - params[18 + ch]);
        precise REAL v = (b0 * a0 + b1 * a1) + b2 * a2;
        out_p[3 * p + ch] = v;
    }
    precise REAL n[3];
    for (int ch = 0; ch < 3; ch++) {
        n[ch] = (b0 * REAL(normals[3 * v0 + ch]) + b1 * REAL(normals[3 * v1 + ch])) + b2 * REAL(normals[3 * v2 + ch]);
    }
    precise REAL len = sqrt((n[0] * n[0] + n[1] * n[1]) + n[2] * n[2]);
    for (int ch = 0; ch < 3; ch++) {
        precise REAL q = n[ch] / len;
        out_n[3 * p + ch] = len > REAL(0.0) ? q : REAL(0.0);
    }
    out_mask[p] = 1;
#else
    int obj = 0;
    if (t >= 0) obj = face_object[tri_info[t].x];
#if MODE == 2
    if (view_id[p] != reflector) obj = 0;   // off the stencil: not this reflector's pixel
#endif
    if (obj == 0) {
        for (int ch = 0; ch < 3; ch++) {
#if MODE == 1
            out_c[3 * p + ch] = shading[5 + ch];   // the background
#else
            out_c[3 * p + ch] = 0.0;
#endif
        }
        out_id[p] = 0;
        return;
    }
    float b0, b1, b2;
    barycentrics(t, row, col, height, b0, b1, b2);
    int f = tri_info[t].x;
    int v0 = faces[3 * f], v1 = faces[3 * f + 1], v2 = faces[3 * f + 2];
    precise float n[3];
    for (int ch = 0; ch < 3; ch++) {
        n[ch] = (b0 * float(normals[3 * v0 + ch]) + b1 * float(normals[3 * v1 + ch])) + b2 * float(normals[3 * v2 + ch]);
    }
    precise float len = sqrt((n[0] * n[0] + n[1] * n[1]) + n[2] * n[2]);
    precise float m[3];
    for (int ch = 0; ch < 3; ch++) m[ch] = len > 0.0 ? n[ch] / len : 0.0;
    precise float lam = abs((m[0] * shading[0] + m[1] * shading[1]) + m[2] * shading[2]);
    precise float k = shading[3] + shading[4] * lam;
    for (int ch = 0; ch < 3; ch++) {
        precise float c = shading[8 + 3 * obj + ch] * k;
        out_c[3 * p + ch] = c;
    }
    out_id[p] = obj;
#endif
}
