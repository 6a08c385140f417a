// The per-pixel search of the layered depth textures (refsoft/ldt/_search.py ``search_pixels``,
// step for step), in REAL: at every stencil pixel the reflected ray, then for every object the
// slab clip of its cube, the cone test's verdict, the faces in order (the entry face, then
// decreasing |u_i|, ties to the smaller axis), each face's linear search and bisection (an open
// object by the crossing rule), and the nearest accepted hit over the objects. Every product
// and sum in refsoft's order, with precise (both variants: docs/ports.md section 7 says why).
#include "common.glsl"

layout(std430, binding = 0) readonly buffer Pixels { int pixel_of[]; };     // (n,): row * W + col
layout(std430, binding = 1) readonly buffer Pos { REAL pos[]; };            // (H, W, 3) world P
layout(std430, binding = 2) readonly buffer Nrm { REAL nrm[]; };            // (H, W, 3) unit N
layout(std430, binding = 3) readonly buffer Tri { int tri_of[]; };          // (n,) reflector triangle
layout(std430, binding = 4) readonly buffer Region { int region[]; };       // (T, K) 0/1
layout(std430, binding = 5) readonly buffer Wm { REAL W[]; };               // (K, 4, 4)
layout(std430, binding = 6) readonly buffer Depth { float depth[]; };       // (K, 6, L, R, R)
layout(std430, binding = 7) readonly buffer Back { REAL back[]; };          // (K, 6, L, R, R)
layout(std430, binding = 8) readonly buffer Count { int count[]; };         // (K, 6, R, R)
layout(std430, binding = 9) readonly buffer Open { int is_open[]; };        // (K,)
layout(std430, binding = 10) readonly buffer Eye { REAL eye_dir[]; };       // eye (3), view direction (3)
layout(std430, binding = 11) writeonly buffer OutReal { REAL out_real[]; }; // (n, 10 + K): see below
layout(std430, binding = 12) writeonly buffer OutInt { int out_int[]; };    // (n, 11)

uniform int n;
uniform int K;
uniform int L;
uniform int R;
uniform int n_lin;        // 0: one step per texel
uniform int max_faces;    // 3, or 1 (the entry face only)
uniform bool ortho;
uniform bool use_regions;
uniform REAL tau;

const int TABLE[24] = int[24](2, -1, 1, -1,  2, 1, 1, -1,  0, 1, 2, 1,  0, 1, 2, -1,  0, 1, 1, -1,  0, -1, 1, -1);
const int START_INSIDE = 1, NO_FACE_WITHIN_TAU = 2, REGION_CULLED = 8, ORIGIN_IN_CUBE = 32;

REAL pick(REAL x, REAL y, REAL z, int a) { return a == 0 ? x : (a == 1 ? y : z); }

int at(int k, int f, int j, int row, int col) { return (((k * 6 + f) * L + j) * R + row) * R + col; }
int cnt(int k, int f, int row, int col) { return count[((k * 6 + f) * R + row) * R + col]; }

REAL int_margin(REAL x, REAL Rf) {
    precise REAL k = floor(x + REAL(0.5));
    if (k > REAL(0.0) && k < Rf) return abs(x - k);
    return REAL(1.0);
}

// face f's texel and axial depth at q0 + s u
void texel(REAL q0x, REAL q0y, REAL q0z, REAL ux, REAL uy, REAL uz, REAL s, int f,
           out int row, out int col, out REAL h, out REAL margin) {
    precise REAL qx = q0x + s * ux;
    precise REAL qy = q0y + s * uy;
    precise REAL qz = q0z + s * uz;
    REAL sc = pick(qx, qy, qz, TABLE[4 * f]);
    if (TABLE[4 * f + 1] < 0) sc = -sc;
    REAL tc = pick(qx, qy, qz, TABLE[4 * f + 2]);
    if (TABLE[4 * f + 3] < 0) tc = -tc;
    REAL Rf = REAL(R);
    precise REAL x = ((sc + REAL(1.0)) * REAL(0.5)) * Rf;
    precise REAL y = ((tc + REAL(1.0)) * REAL(0.5)) * Rf;
    col = min(max(int(floor(x)), 0), R - 1);
    row = R - 1 - min(max(int(floor(y)), 0), R - 1);
    REAL qa = pick(qx, qy, qz, f / 2);
    precise REAL hh = (f % 2 == 0) ? REAL(0.5) * (REAL(1.0) - qa) : REAL(0.5) * (REAL(1.0) + qa);
    h = hh;
    margin = min(int_margin(x, Rf), int_margin(y, Rf));
}

// One face's linear search and bisection; returns found.
bool face_search(REAL q0x, REAL q0y, REAL q0z, REAL ux, REAL uy, REAL uz, REAL s_in, REAL s_out, REAL umax,
                 int f, int k, out REAL s_hit, out int layer, out int hrow, out int hcol, out REAL residual,
                 out int samples, out int steps, inout REAL margin, out bool start_inside) {
    REAL Rf = REAL(R);
    int nn;
    if (n_lin > 0) {
        nn = n_lin;
    } else {
        precise REAL span = ((umax * (s_out - s_in)) * Rf) * REAL(0.5);
        nn = min(max(int(ceil(span)), 1), 4 * R);
    }
    precise REAL D = (s_out - s_in) / REAL(nn);
    int found_j = -1;
    int m = 0;
    int row = 0, col = 0;
    REAL h = REAL(0.0);
    bool sheet = is_open[k] != 0;
    bool in_front = false;
    s_hit = REAL(0.0); layer = -1; hrow = 0; hcol = 0; residual = REAL(0.0); steps = 0; start_inside = false;
    for (m = 0; m <= nn; m++) {
        precise REAL sm = s_in + REAL(m) * D;
        REAL mt;
        texel(q0x, q0y, q0z, ux, uy, uz, sm, f, row, col, h, mt);
        margin = min(margin, mt);
        bool front = false;
        int c = cnt(k, f, row, col);
        for (int j = 0; j < c; j++) {
            REAL z = REAL(depth[at(k, f, j, row, col)]);
            margin = min(margin, abs(h - z));
            if (h < z) { front = true; break; }
            REAL d = back[at(k, f, j, row, col)];
            margin = min(margin, abs(h - d));
            if (h <= d) {
                if (in_front || !sheet) found_j = j;
                break;
            }
        }
        if (found_j >= 0) break;
        in_front = front;
    }
    if (m > nn) m = nn;   // the loop ran out: GLSL's counter has gone one past the last sample
    samples = m + 1;
    if (found_j < 0) return false;
    int j = found_j;
    layer = j;
    if (m == 0) {
        precise REAL e = (h - REAL(depth[at(k, f, j, row, col)])) * Rf;
        s_hit = s_in; hrow = row; hcol = col; residual = e; start_inside = true;
        return true;
    }
    precise REAL lo = s_in + REAL(m - 1) * D;
    precise REAL hi = s_in + REAL(m) * D;
    precise REAL len = ((D * umax) * Rf) * REAL(0.5);
    int st = 0;
    while (len > REAL(0.125) && st < 16) { len = len * REAL(0.5); st++; }
    int row_hi = row, col_hi = col;
    REAL h_hi = h;
    for (int b = 0; b < st; b++) {
        precise REAL mid = REAL(0.5) * (lo + hi);
        int r, c;
        REAL hm, mt;
        texel(q0x, q0y, q0z, ux, uy, uz, mid, f, r, c, hm, mt);
        margin = min(margin, mt);
        bool inside = false;
        if (j < cnt(k, f, r, c)) {
            REAL z = REAL(depth[at(k, f, j, r, c)]);
            REAL d = back[at(k, f, j, r, c)];
            margin = min(margin, min(abs(hm - z), abs(hm - d)));
            inside = z <= hm && hm <= d;
        }
        if (inside) { hi = mid; row_hi = r; col_hi = c; h_hi = hm; } else { lo = mid; }
    }
    precise REAL e = (h_hi - REAL(depth[at(k, f, j, row_hi, col_hi)])) * Rf;
    s_hit = hi; hrow = row_hi; hcol = col_hi; residual = e; steps = st;
    return true;
}

void main() {
    uint iu = gid();
    if (iu >= uint(n)) return;
    int i = int(iu);
    int p = pixel_of[i];
    REAL px = pos[3 * p], py = pos[3 * p + 1], pz = pos[3 * p + 2];
    precise REAL ix, iy, iz;
    if (ortho) {
        ix = eye_dir[3]; iy = eye_dir[4]; iz = eye_dir[5];
    } else {
        precise REAL dx = px - eye_dir[0], dy = py - eye_dir[1], dz = pz - eye_dir[2];
        precise REAL length = sqrt((dx * dx + dy * dy) + dz * dz);
        ix = dx / length; iy = dy / length; iz = dz / length;
    }
    REAL nx = nrm[3 * p], ny = nrm[3 * p + 1], nz = nrm[3 * p + 2];
    precise REAL kk = REAL(2.0) * ((nx * ix + ny * iy) + nz * iz);
    precise REAL rx = ix - kk * nx, ry = iy - kk * ny, rz = iz - kk * nz;
    int stride = 10 + K;
    out_real[stride * i] = rx; out_real[stride * i + 1] = ry; out_real[stride * i + 2] = rz;
    int flags = 0;
#if DOUBLE
    REAL inf = packDouble2x32(uvec2(0u, 0x7ff00000u));
#else
    REAL inf = uintBitsToFloat(0x7f800000u);
#endif
    REAL best_t = inf;
    int best_k = -1, best_f = -1, best_j = -1, best_r = -1, best_c = -1, best_flags = 0;
    REAL best_e = REAL(0.0), best_m = REAL(0.0);
    REAL any_margin = REAL(1.0);
    int samples = 0, steps = 0, faces = 0, objects = 0;
    for (int k = 0; k < K; k++) {
        out_real[stride * i + 10 + k] = REAL(-1.0);
        int w = 16 * k;
        precise REAL q0x = ((W[w] * px + W[w + 1] * py) + W[w + 2] * pz) + W[w + 3];
        precise REAL q0y = ((W[w + 4] * px + W[w + 5] * py) + W[w + 6] * pz) + W[w + 7];
        precise REAL q0z = ((W[w + 8] * px + W[w + 9] * py) + W[w + 10] * pz) + W[w + 11];
        precise REAL ux = (W[w] * rx + W[w + 1] * ry) + W[w + 2] * rz;
        precise REAL uy = (W[w + 4] * rx + W[w + 5] * ry) + W[w + 6] * rz;
        precise REAL uz = (W[w + 8] * rx + W[w + 9] * ry) + W[w + 10] * rz;
        REAL near = -inf, far = inf;
        int entry = -1;
        bool miss = false;
        for (int a = 0; a < 3; a++) {
            REAL qa = pick(q0x, q0y, q0z, a);
            REAL ua = pick(ux, uy, uz, a);
            if (ua == REAL(0.0)) {
                if (abs(qa) > REAL(1.0)) miss = true;
                continue;
            }
            precise REAL s_lo = (REAL(-1.0) - qa) / ua;
            precise REAL s_hi = (REAL(1.0) - qa) / ua;
            if (s_hi < s_lo) { REAL tmp = s_lo; s_lo = s_hi; s_hi = tmp; }
            if (s_lo > near) { near = s_lo; entry = a; }
            far = min(far, s_hi);
        }
        REAL s_in = max(REAL(0.0), near);
        if (miss || entry < 0 || !(s_in < far)) continue;
        if (use_regions && region[tri_of[i] * K + k] == 0) { flags |= REGION_CULLED; continue; }
        objects++;
        if (!(near > REAL(0.0))) { flags |= ORIGIN_IN_CUBE; entry = -1; }
        REAL s_out = far;
        REAL aux = abs(ux), auy = abs(uy), auz = abs(uz);
        REAL umax = max(aux, max(auy, auz));
        int order[3];
        int n_order = 0;
        if (entry >= 0) { order[0] = entry; n_order = 1; }
        for (int it = 0; it < 3; it++) {
            int pk = -1;
            REAL best_u = REAL(0.0);
            for (int a = 0; a < 3; a++) {
                bool taken = false;
                for (int b = 0; b < n_order; b++) if (order[b] == a) taken = true;
                REAL ua = pick(aux, auy, auz, a);
                if (!taken && ua > best_u) { pk = a; best_u = ua; }
            }
            if (pk < 0) break;
            order[n_order] = pk;
            n_order++;
        }
        n_order = min(n_order, max_faces);
        bool got = false, accepted = false;
        REAL cand_e = inf;
        REAL c_s = REAL(0.0), c_res = REAL(0.0), c_margin = REAL(0.0);
        int c_layer = -1, c_row = 0, c_col = 0, cand_f = -1;
        bool c_start = false;
        for (int b = 0; b < n_order; b++) {
            int a = order[b];
            REAL ua = pick(ux, uy, uz, a);
            int f = 2 * a + (ua > REAL(0.0) ? 1 : 0);
            REAL s_hit, res_e, fm = REAL(1.0);
            int lay, hr, hc, smp, stp;
            bool start;
            bool found = face_search(q0x, q0y, q0z, ux, uy, uz, s_in, s_out, umax, f, k, s_hit, lay, hr, hc, res_e,
                                     smp, stp, fm, start);
            faces++;
            samples += smp;
            steps += stp;
            any_margin = min(any_margin, fm);
            if (!found) continue;
            if (res_e <= tau) {
                c_s = s_hit; c_layer = lay; c_row = hr; c_col = hc; c_res = res_e; c_margin = fm; c_start = start;
                cand_f = f; got = true; accepted = true;
                break;
            }
            if (res_e < cand_e) {
                cand_e = res_e;
                c_s = s_hit; c_layer = lay; c_row = hr; c_col = hc; c_res = res_e; c_margin = fm; c_start = start;
                cand_f = f; got = true;
            }
        }
        if (!got) continue;
        out_real[stride * i + 10 + k] = c_s;
        if (c_s < best_t) {
            best_t = c_s; best_k = k; best_f = cand_f; best_j = c_layer; best_r = c_row; best_c = c_col;
            best_e = c_res; best_m = c_margin;
            best_flags = (c_start ? START_INSIDE : 0) | (accepted ? 0 : NO_FACE_WITHIN_TAU);
        }
    }
    // out_int: object, face, layer, row, col, samples, steps, faces, objects, flags (the host adds
    // the mismatch and open bits, which read the textures at the hit)
    int o = 11 * i;
    out_int[o + 5] = samples; out_int[o + 6] = steps;
    out_int[o + 7] = min(faces, 127); out_int[o + 8] = min(objects, 127);
    if (best_k < 0) {
        out_int[o] = -1; out_int[o + 1] = -1; out_int[o + 2] = -1; out_int[o + 3] = -1; out_int[o + 4] = -1;
        out_int[o + 9] = flags;
        out_real[stride * i + 3] = REAL(-1.0);   // distance
        out_real[stride * i + 4] = REAL(0.0);    // residual
        out_real[stride * i + 5] = any_margin;   // margin
        for (int c = 6; c < 9; c++) out_real[stride * i + c] = REAL(0.0);   // hit position
        return;
    }
    out_int[o] = best_k; out_int[o + 1] = best_f; out_int[o + 2] = best_j; out_int[o + 3] = best_r;
    out_int[o + 4] = best_c; out_int[o + 9] = flags | best_flags;
    out_real[stride * i + 3] = best_t;
    out_real[stride * i + 4] = best_e;
    out_real[stride * i + 5] = best_m;
    precise REAL hx = px + best_t * rx, hy = py + best_t * ry, hz = pz + best_t * rz;
    out_real[stride * i + 6] = hx; out_real[stride * i + 7] = hy; out_real[stride * i + 8] = hz;
}
