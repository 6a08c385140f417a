// Virtual vertices (spec section 4.6; refsoft/search/_virtual.py), in REAL relative to the
// origin: V for a CULLED vertex; for a HIDDEN one by the mode (0 plane: (P + N (2 d.N)) - d,
// 1 search: V, 2 discard: the mirror); else the mirror V - (2 d.N) N, d = V - P_R. Written:
// the float32 world vertex (the output) and the float64 world vertex origin + V' (drawn).
// With ``unfold`` a visible vertex's V' is P + normalize(P - O) |d| instead of the mirror; with
// SURFACE 1, P and N are per-vertex sub-texel points (refine.comp), not the pixel's.
#include "common.glsl"
#ifndef SURFACE
#define SURFACE 0
#endif

layout(std430, binding = 0) readonly buffer GP { REAL gp[]; };
layout(std430, binding = 1) readonly buffer GN { REAL gn[]; };
layout(std430, binding = 4) readonly buffer Vertices { double vertices[]; };
layout(std430, binding = 5) readonly buffer Params { double params[]; };
layout(std430, binding = 7) readonly buffer Pixel { ivec2 pixel[]; };
#if SURFACE
layout(std430, binding = 2) readonly buffer SP { REAL sp[]; };   // (N, 3) sub-texel points (refine.comp)
layout(std430, binding = 3) readonly buffer SN { REAL sn[]; };   // (N, 3) their normals
#endif
layout(std430, binding = 11) readonly buffer Flags { uint flags[]; };
layout(std430, binding = 12) writeonly buffer OutV { float out_v[]; };       // (N, 3) float32 world
layout(std430, binding = 13) writeonly buffer OutV64 { double out_v64[]; };  // (N, 3) float64 world

uniform int n;
uniform int gwidth;
uniform int mode;
uniform bool unfold;   // visible vertices on the eye's ray through the point, at the path's length

void main() {
    uint iu = gid();
    if (iu >= uint(n)) return;
    int i = int(iu);
    precise REAL vx = REAL(vertices[3 * i] - params[18]);
    precise REAL vy = REAL(vertices[3 * i + 1] - params[19]);
    precise REAL vz = REAL(vertices[3 * i + 2] - params[20]);
    uint fl = flags[i];
#if SURFACE
    int p = 3 * i;
    REAL px = sp[p], py = sp[p + 1], pz = sp[p + 2];
    REAL nx = sn[p], ny = sn[p + 1], nz = sn[p + 2];
#else
    ivec2 q = max(pixel[i], ivec2(0));
    int p = 3 * (q.x * gwidth + q.y);
    REAL px = gp[p], py = gp[p + 1], pz = gp[p + 2];
    REAL nx = gn[p], ny = gn[p + 1], nz = gn[p + 2];
#endif
    precise REAL ox, oy, oz;
    if ((fl & 16u) != 0u) {
        ox = vx; oy = vy; oz = vz;
    } else {
        precise REAL dx = vx - px, dy = vy - py, dz = vz - pz;
        precise REAL length = sqrt((dx * dx + dy * dy) + dz * dz);
        precise REAL ex = REAL(params[21] - params[18]), ey = REAL(params[22] - params[19]), ez = REAL(params[23] - params[20]);
        precise REAL qx = px - ex, qy = py - ey, qz = pz - ez;
        precise REAL ql = sqrt((qx * qx + qy * qy) + qz * qz);
        precise REAL qi = REAL(1.0) / ql;
        precise REAL ux = qx * qi, uy = qy * qi, uz = qz * qi;
        if (!(ql > REAL(0.0))) { ux = REAL(0.0); uy = REAL(0.0); uz = REAL(0.0); }
        precise REAL dn = (dx * nx + dy * ny) + dz * nz;
        precise REAL k = REAL(2.0) * dn;
        if (unfold && (fl & 1u) == 0u) {
            ox = px + ux * length; oy = py + uy * length; oz = pz + uz * length;
        } else if ((fl & 1u) != 0u && mode == 0) {
            ox = (px + nx * k) - dx; oy = (py + ny * k) - dy; oz = (pz + nz * k) - dz;
        } else if ((fl & 1u) != 0u && mode == 1) {
            ox = vx; oy = vy; oz = vz;
        } else {
            ox = vx - k * nx; oy = vy - k * ny; oz = vz - k * nz;
        }
    }
    precise double wx = double(ox) + params[18];
    precise double wy = double(oy) + params[19];
    precise double wz = double(oz) + params[20];
    out_v64[3 * i] = wx; out_v64[3 * i + 1] = wy; out_v64[3 * i + 2] = wz;
    out_v[3 * i] = float(wx); out_v[3 * i + 1] = float(wy); out_v[3 * i + 2] = float(wz);
}
