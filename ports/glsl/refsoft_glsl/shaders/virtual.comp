// Virtual vertices (spec section 4.6; refsoft/search/_virtual.py), in REAL relative to the
// origin: V for a CULLED vertex; for a HIDDEN one by the mode (0 plane: (P + N (2 d.N)) - d,
// 1 search: V, 2 discard: the mirror); else the mirror V - (2 d.N) N, d = V - P_R. Written:
// the float32 world vertex (the output) and the float64 world vertex origin + V' (drawn).
#include "common.glsl"

layout(std430, binding = 0) readonly buffer GP { REAL gp[]; };
layout(std430, binding = 1) readonly buffer GN { REAL gn[]; };
layout(std430, binding = 4) readonly buffer Vertices { double vertices[]; };
layout(std430, binding = 5) readonly buffer Params { double params[]; };
layout(std430, binding = 7) readonly buffer Pixel { ivec2 pixel[]; };
layout(std430, binding = 11) readonly buffer Flags { uint flags[]; };
layout(std430, binding = 12) writeonly buffer OutV { float out_v[]; };       // (N, 3) float32 world
layout(std430, binding = 13) writeonly buffer OutV64 { double out_v64[]; };  // (N, 3) float64 world

uniform int n;
uniform int gwidth;
uniform int mode;

void main() {
    uint iu = gid();
    if (iu >= uint(n)) return;
    int i = int(iu);
    precise REAL vx = REAL(vertices[3 * i] - params[18]);
    precise REAL vy = REAL(vertices[3 * i + 1] - params[19]);
    precise REAL vz = REAL(vertices[3 * i + 2] - params[20]);
    uint fl = flags[i];
    ivec2 q = max(pixel[i], ivec2(0));
    int p = 3 * (q.x * gwidth + q.y);
    REAL px = gp[p], py = gp[p + 1], pz = gp[p + 2];
    REAL nx = gn[p], ny = gn[p + 1], nz = gn[p + 2];
    precise REAL ox, oy, oz;
    if ((fl & 16u) != 0u) {
        ox = vx; oy = vy; oz = vz;
    } else {
        precise REAL dx = vx - px, dy = vy - py, dz = vz - pz;
        precise REAL dn = (dx * nx + dy * ny) + dz * nz;
        precise REAL k = REAL(2.0) * dn;
        if ((fl & 1u) != 0u && mode == 0) {
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
