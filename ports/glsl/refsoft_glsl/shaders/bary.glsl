// Perspective-correct barycentrics of pixel (row, col) w.r.t. the input triangle of clip
// triangle t (refsoft/raster/_kernels.py ``_barycentrics``), in REAL: a_i = e_i * (1/w_i),
// l_i = a_i / ((a0 + a1) + a2), then through the clip vertices' barycentrics (slot >= 0),
// the identity (-1) or vertices 1 and 2 swapped (-2).
layout(std430, binding = 1) readonly buffer TriXY { ivec2 tri_xy[]; };
layout(std430, binding = 2) readonly buffer TriZW { dvec2 tri_zw[]; };
layout(std430, binding = 3) readonly buffer TriInfo { ivec4 tri_info[]; };
layout(std430, binding = 4) readonly buffer Bary { double bary[]; };

void barycentrics(int t, int row, int col, int height, out REAL b0, out REAL b1, out REAL b2) {
    int64_t py = int64_t(height - 1 - row) * 256l + 128l;
    int64_t px = int64_t(col) * 256l + 128l;
    int64_t x0 = int64_t(tri_xy[3 * t].x), y0 = int64_t(tri_xy[3 * t].y);
    int64_t x1 = int64_t(tri_xy[3 * t + 1].x), y1 = int64_t(tri_xy[3 * t + 1].y);
    int64_t x2 = int64_t(tri_xy[3 * t + 2].x), y2 = int64_t(tri_xy[3 * t + 2].y);
    precise REAL a0 = REAL((x2 - x1) * (py - y1) - (y2 - y1) * (px - x1)) * REAL(tri_zw[3 * t].y);
    precise REAL a1 = REAL((x0 - x2) * (py - y2) - (y0 - y2) * (px - x2)) * REAL(tri_zw[3 * t + 1].y);
    precise REAL a2 = REAL((x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)) * REAL(tri_zw[3 * t + 2].y);
    precise REAL s = (a0 + a1) + a2;
    precise REAL l0 = a0 / s;
    precise REAL l1 = a1 / s;
    precise REAL l2 = a2 / s;
    int k = tri_info[t].y;
    if (k == -1) {
        b0 = l0; b1 = l1; b2 = l2;
    } else if (k == -2) {
        b0 = l0; b1 = l2; b2 = l1;
    } else {
        precise REAL c0 = (l0 * REAL(bary[9 * k]) + l1 * REAL(bary[9 * k + 3])) + l2 * REAL(bary[9 * k + 6]);
        precise REAL c1 = (l0 * REAL(bary[9 * k + 1]) + l1 * REAL(bary[9 * k + 4])) + l2 * REAL(bary[9 * k + 7]);
        precise REAL c2 = (l0 * REAL(bary[9 * k + 2]) + l1 * REAL(bary[9 * k + 5])) + l2 * REAL(bary[9 * k + 8]);
        b0 = c0; b1 = c1; b2 = c2;
    }
}
