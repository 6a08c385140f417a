// The search's score (spec section 4.1), written out in refsoft's order (refsoft/search/_lanes.py
// ``score_batch``): normalize(x) = x * (1 / sqrt((x.x x.x + x.y x.y) + x.z x.z)), zero for a
// zero vector; s = (N.x h.x + N.y h.y) + N.z h.z, h = normalize(U + normalize(V - P)),
// U = normalize(O - P). The inverse score replaces V by W = V - 2 dot(V - P, N) N.
// With EXACT 0 (the plain variant) the same formula with GLSL's normalize() and dot().
layout(std430, binding = 0) readonly buffer GP { REAL gp[]; };      // (H, W, 3) relative to the origin
layout(std430, binding = 1) readonly buffer GN { REAL gn[]; };      // (H, W, 3)
layout(std430, binding = 2) readonly buffer GM { int gmask[]; };    // (H, W)

uniform int gwidth;
uniform int gheight;

#if DOUBLE
#define VEC3 dvec3
#else
#define VEC3 vec3
#endif

#if EXACT
VEC3 normalize_exact(REAL x, REAL y, REAL z) {
    precise REAL len = sqrt((x * x + y * y) + z * z);
    precise REAL q = REAL(1.0) / len;
    precise REAL ox = x * q;
    precise REAL oy = y * q;
    precise REAL oz = z * q;
    bool pos = len > REAL(0.0);
    return pos ? VEC3(ox, oy, oz) : VEC3(REAL(0.0));
}

REAL score_at(int r, int c, VEC3 e, VEC3 v, bool inverse) {
    int p = 3 * (r * gwidth + c);
    REAL px = gp[p], py = gp[p + 1], pz = gp[p + 2];
    REAL nx = gn[p], ny = gn[p + 1], nz = gn[p + 2];
    precise REAL t = REAL(2.0) * (((v.x - px) * nx + (v.y - py) * ny) + (v.z - pz) * nz);
    precise REAL wx = v.x - t * nx;
    precise REAL wy = v.y - t * ny;
    precise REAL wz = v.z - t * nz;
    if (!inverse) { wx = v.x; wy = v.y; wz = v.z; }
    precise REAL ex = e.x - px, ey = e.y - py, ez = e.z - pz;
    VEC3 u = normalize_exact(ex, ey, ez);
    precise REAL dx = wx - px, dy = wy - py, dz = wz - pz;
    VEC3 b = normalize_exact(dx, dy, dz);
    precise REAL sx = u.x + b.x, sy = u.y + b.y, sz = u.z + b.z;
    VEC3 h = normalize_exact(sx, sy, sz);
    precise REAL s = (nx * h.x + ny * h.y) + nz * h.z;
    return s;
}

REAL dot_exact(VEC3 a, VEC3 b) {
    precise REAL d = (a.x * b.x + a.y * b.y) + a.z * b.z;
    return d;
}

VEC3 unit3(REAL x, REAL y, REAL z) {
    return normalize_exact(x, y, z);
}
#else
VEC3 safe_normalize(VEC3 x) {
    return length(x) > REAL(0.0) ? normalize(x) : VEC3(REAL(0.0));
}

REAL score_at(int r, int c, VEC3 e, VEC3 v, bool inverse) {
    int p = 3 * (r * gwidth + c);
    VEC3 P = VEC3(gp[p], gp[p + 1], gp[p + 2]);
    VEC3 N = VEC3(gn[p], gn[p + 1], gn[p + 2]);
    VEC3 w = inverse ? v - REAL(2.0) * dot(v - P, N) * N : v;
    VEC3 h = safe_normalize(safe_normalize(e - P) + safe_normalize(w - P));
    return dot(N, h);
}

REAL dot_exact(VEC3 a, VEC3 b) {
    return dot(a, b);
}

VEC3 unit3(REAL x, REAL y, REAL z) {
    return safe_normalize(VEC3(x, y, z));
}
#endif

bool covered(int r, int c) {
    return r >= 0 && r < gheight && c >= 0 && c < gwidth && gmask[r * gwidth + c] != 0;
}
