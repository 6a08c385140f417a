// Sub-texel reflection points (refsoft/search/_refine.py ``refine``), one invocation per vertex:
// one Gauss-Newton step on N(x) - h(x) = 0 from the reflection texel, the residual's derivatives
// by central differences, the step clamped to one texel per axis, P and N there by the
// first-order model. CULLED: zeros; HIDDEN: the texel's P and N; offset 0 for both.
#include "common.glsl"
#include "score.glsl"
#include "surface.glsl"

layout(std430, binding = 4) readonly buffer Vertices { double vertices[]; };
layout(std430, binding = 5) readonly buffer Params { double params[]; };
layout(std430, binding = 7) readonly buffer Pixel { ivec2 pixel[]; };
layout(std430, binding = 11) readonly buffer Flags { uint flags[]; };
layout(std430, binding = 12) writeonly buffer OutP { REAL out_p[]; };
layout(std430, binding = 13) writeonly buffer OutN { REAL out_n[]; };
layout(std430, binding = 14) writeonly buffer OutOff { REAL out_off[]; };

uniform int n;

VEC3 residual(int r, int c, VEC3 v, VEC3 e) {
    int p = 3 * (r * gwidth + c);
    REAL px = gp[p], py = gp[p + 1], pz = gp[p + 2];
    precise REAL ex = e.x - px, ey = e.y - py, ez = e.z - pz;
    VEC3 u = unit3(ex, ey, ez);
    precise REAL bx = v.x - px, by = v.y - py, bz = v.z - pz;
    VEC3 b = unit3(bx, by, bz);
    precise REAL sx = u.x + b.x, sy = u.y + b.y, sz = u.z + b.z;
    VEC3 h = unit3(sx, sy, sz);
    precise REAL rx = gn[p] - h.x, ry = gn[p + 1] - h.y, rz = gn[p + 2] - h.z;
    return VEC3(rx, ry, rz);
}

void main() {
    uint iu = gid();
    if (iu >= uint(n)) return;
    int i = int(iu);
    int r = pixel[i].x, c = pixel[i].y;
    uint fl = flags[i];
    out_off[2 * i] = REAL(0.0);
    out_off[2 * i + 1] = REAL(0.0);
    if ((fl & 16u) != 0u) {
        for (int k = 0; k < 3; k++) { out_p[3 * i + k] = REAL(0.0); out_n[3 * i + k] = REAL(0.0); }
        return;
    }
    int p = 3 * (r * gwidth + c);
    if ((fl & 1u) != 0u) {
        for (int k = 0; k < 3; k++) { out_p[3 * i + k] = gp[p + k]; out_n[3 * i + k] = gn[p + k]; }
        return;
    }
    precise double dvx = vertices[3 * i] - params[18];
    precise double dvy = vertices[3 * i + 1] - params[19];
    precise double dvz = vertices[3 * i + 2] - params[20];
    VEC3 v = VEC3(REAL(dvx), REAL(dvy), REAL(dvz));
    precise double dex = params[21] - params[18];
    precise double dey = params[22] - params[19];
    precise double dez = params[23] - params[20];
    VEC3 e = VEC3(REAL(dex), REAL(dey), REAL(dez));
    VEC3 d0 = residual(r, c, v, e);
    REAL sa, sb;
    ivec4 A = fd_stencil(r, c, 1, 0, sa);
    VEC3 pa = residual(A.x, A.y, v, e), pb = residual(A.z, A.w, v, e);
    ivec4 B = fd_stencil(r, c, 0, 1, sb);
    VEC3 pc = residual(B.x, B.y, v, e), pd = residual(B.z, B.w, v, e);
    precise REAL j00 = (pa.x - pb.x) * sa, j01 = (pa.y - pb.y) * sa, j02 = (pa.z - pb.z) * sa;
    precise REAL j10 = (pc.x - pd.x) * sb, j11 = (pc.y - pd.y) * sb, j12 = (pc.z - pd.z) * sb;
    precise REAL a00 = (j00 * j00 + j01 * j01) + j02 * j02;
    precise REAL a01 = (j00 * j10 + j01 * j11) + j02 * j12;
    precise REAL a11 = (j10 * j10 + j11 * j11) + j12 * j12;
    precise REAL b0 = -((j00 * d0.x + j01 * d0.y) + j02 * d0.z);
    precise REAL b1 = -((j10 * d0.x + j11 * d0.y) + j12 * d0.z);
    precise REAL det = a00 * a11 - a01 * a01;
    precise REAL lim_det = REAL(MIN_DET) * (a00 * a11);
    precise REAL t0 = REAL(0.0), t1 = REAL(0.0);
    if (det > lim_det) {
        t0 = (a11 * b0 - a01 * b1) / det;
        t1 = (a00 * b1 - a01 * b0) / det;
    } else if (a11 == REAL(0.0) && a00 > REAL(0.0)) {
        t0 = b0 / a00;
    } else if (a00 == REAL(0.0) && a11 > REAL(0.0)) {
        t1 = b1 / a11;
    }
    t0 = min(max(t0, REAL(-1.0)), REAL(1.0));
    t1 = min(max(t1, REAL(-1.0)), REAL(1.0));
    out_off[2 * i] = t0;
    out_off[2 * i + 1] = t1;
    VEC3 P, N;
    surface_values(r, c, t0, t1, P, N);
    for (int k = 0; k < 3; k++) { out_p[3 * i + k] = P[k]; out_n[3 * i + k] = N[k]; }
}
