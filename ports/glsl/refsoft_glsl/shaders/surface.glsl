// The first-order surface model of the sub-texel refinement (refsoft/search/_refine.py
// ``surface_values``): P and unit N at (r + t0, c + t1) from texel (r, c) and central
// differences over its covered neighbours (one-sided beside an uncovered one, none when
// neither is). Needs GP, GN, GM, gwidth, gheight and unit3 (score.glsl).

// (r_plus, c_plus, r_minus, c_minus) and the difference's scale along (dr, dc)
ivec4 fd_stencil(int r, int c, int dr, int dc, out REAL scale) {
    bool minus = covered(r - dr, c - dc), plus = covered(r + dr, c + dc);
    if (minus && plus) { scale = REAL(0.5); return ivec4(r + dr, c + dc, r - dr, c - dc); }
    if (plus) { scale = REAL(1.0); return ivec4(r + dr, c + dc, r, c); }
    if (minus) { scale = REAL(1.0); return ivec4(r, c, r - dr, c - dc); }
    scale = REAL(0.0);
    return ivec4(r, c, r, c);
}

void surface_values(int r, int c, REAL t0, REAL t1, out VEC3 P, out VEC3 N) {
    REAL sa, sb;
    ivec4 A = fd_stencil(r, c, 1, 0, sa);
    ivec4 B = fd_stencil(r, c, 0, 1, sb);
    precise REAL ka = t0 * sa;
    precise REAL kb = t1 * sb;
    int p0 = 3 * (r * gwidth + c), pa = 3 * (A.x * gwidth + A.y), pb = 3 * (A.z * gwidth + A.w);
    int pc = 3 * (B.x * gwidth + B.y), pd = 3 * (B.z * gwidth + B.w);
    precise REAL o[6];
    for (int k = 0; k < 3; k++) {
        o[k] = (gp[p0 + k] + ka * (gp[pa + k] - gp[pb + k])) + kb * (gp[pc + k] - gp[pd + k]);
        o[3 + k] = (gn[p0 + k] + ka * (gn[pa + k] - gn[pb + k])) + kb * (gn[pc + k] - gn[pd + k]);
    }
    P = VEC3(o[0], o[1], o[2]);
    N = unit3(o[3], o[4], o[5]);
}
