// Triangle setup (refsoft/raster/_setup.py ``emit_clip_triangles``): per input triangle, its
// clip triangles in order, counter-clockwise on screen (vertices 1 and 2 swapped when not),
// with snapped x, y, window depth, 1/w, the doubled area, the edge biases of the fill rule
// (0 inclusive for left and bottom edges, -1 exclusive) and the pixel box clamped to the region.
#include "common.glsl"
#include "clip.glsl"

layout(std430, binding = 0) readonly buffer Faces { int faces[]; };
layout(std430, binding = 1) readonly buffer Clip { dvec4 clip[]; };
layout(std430, binding = 2) readonly buffer WinXY { ivec2 win_xy[]; };
layout(std430, binding = 3) readonly buffer WinZW { dvec2 win_zw[]; };
layout(std430, binding = 4) readonly buffer Offsets { int offsets[]; };        // (F + 1,)
layout(std430, binding = 5) readonly buffer ClipOffsets { int clip_offsets[]; };
layout(std430, binding = 6) readonly buffer Params { double params[]; };
layout(std430, binding = 7) writeonly buffer TriXY { ivec2 tri_xy[]; };        // (T, 3): x, y
layout(std430, binding = 8) writeonly buffer TriZW { dvec2 tri_zw[]; };        // (T, 3): z_w, 1/w
layout(std430, binding = 9) writeonly buffer TriInfo { ivec4 tri_info[]; };    // (T,): input triangle, slot, valid, -
layout(std430, binding = 10) writeonly buffer TriBox { ivec4 tri_box[]; };     // (T,): col0, col1, row0, row1
layout(std430, binding = 11) writeonly buffer TriEdge { i64vec4 tri_edge[]; }; // (T,): bias 0..2, doubled area
layout(std430, binding = 12) writeonly buffer Bary { double bary[]; };         // (K, 3, 3)

uniform int n;
uniform int width;
uniform int height;
uniform ivec4 region;   // rows region.x..region.y, cols region.z..region.w (inclusive)
uniform int cull;       // 0 both windings; 1 only clockwise (snapped a2 < 0, y up); 2 only counter-clockwise

const int64_t ONE = 256l;
const int64_t HALF = 128l;

// Stores clip triangle t; returns true when vertices 1 and 2 were swapped.
bool emit(int t, int f, int64_t x0, int64_t y0, dvec2 zw0, int64_t x1, int64_t y1, dvec2 zw1,
          int64_t x2, int64_t y2, dvec2 zw2) {
    int64_t a2 = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0);
    bool kept = cull == 0 || (cull == 1 && a2 < 0l) || (cull == 2 && a2 > 0l);   // a culled one: stored, not valid
    bool swapped = a2 < 0l;
    if (swapped) {
        a2 = -a2;
        int64_t tx = x1, ty = y1;
        dvec2 tz = zw1;
        x1 = x2; y1 = y2; zw1 = zw2;
        x2 = tx; y2 = ty; zw2 = tz;
    }
    tri_xy[3 * t] = ivec2(int(x0), int(y0));
    tri_xy[3 * t + 1] = ivec2(int(x1), int(y1));
    tri_xy[3 * t + 2] = ivec2(int(x2), int(y2));
    tri_zw[3 * t] = zw0;
    tri_zw[3 * t + 1] = zw1;
    tri_zw[3 * t + 2] = zw2;
    int64_t b0 = (y2 - y1 < 0l || (y2 == y1 && x2 - x1 > 0l)) ? 0l : -1l;
    int64_t b1 = (y0 - y2 < 0l || (y0 == y2 && x0 - x2 > 0l)) ? 0l : -1l;
    int64_t b2 = (y1 - y0 < 0l || (y1 == y0 && x1 - x0 > 0l)) ? 0l : -1l;
    tri_edge[t] = i64vec4(b0, b1, b2, a2);
    int64_t xmin = min(x0, min(x1, x2)), xmax = max(x0, max(x1, x2));
    int64_t ymin = min(y0, min(y1, y2)), ymax = max(y0, max(y1, y2));
    int64_t k0 = max((xmin - HALF + (ONE - 1l)) >> 8, 0l);
    int64_t k1 = min((xmax - HALF) >> 8, int64_t(width - 1));
    int64_t j0 = max((ymin - HALF + (ONE - 1l)) >> 8, 0l);
    int64_t j1 = min((ymax - HALF) >> 8, int64_t(height - 1));
    int64_t top = max(int64_t(height - 1) - j1, int64_t(region.x));
    int64_t bottom = min(int64_t(height - 1) - j0, int64_t(region.y));
    k0 = max(k0, int64_t(region.z));
    k1 = min(k1, int64_t(region.w));
    bool valid = kept && a2 != 0l && k0 <= k1 && top <= bottom;
    tri_box[t] = ivec4(int(k0), int(k1), int(top), int(bottom));
    tri_info[t] = ivec4(f, 0, valid ? 1 : 0, 0);
    return swapped;
}

void window_of(dvec4 c, out int64_t x, out int64_t y, out dvec2 zw) {
    precise double wx = (c.x / c.w + 1.0lf) * (0.5lf * double(width));
    precise double wy = (c.y / c.w + 1.0lf) * (0.5lf * double(height));
    precise double sx = wx * 256.0lf;
    precise double sy = wy * 256.0lf;
    x = int64_t(int(roundEven(sx)));
    y = int64_t(int(roundEven(sy)));
    precise double z = 0.5lf * (c.z / c.w) + 0.5lf;
    precise double iw = 1.0lf / c.w;
    zw = dvec2(z, iw);
}

void main() {
    uint fu = gid();
    if (fu >= uint(n)) return;
    int f = int(fu);
    int start = offsets[f];
    int count = offsets[f + 1] - start;
    if (count == 0) return;
    int v0 = faces[3 * f], v1 = faces[3 * f + 1], v2 = faces[3 * f + 2];
    if (clip_offsets[f + 1] == clip_offsets[f]) {
        bool sw = emit(start, f, int64_t(win_xy[v0].x), int64_t(win_xy[v0].y), win_zw[v0],
                       int64_t(win_xy[v1].x), int64_t(win_xy[v1].y), win_zw[v1],
                       int64_t(win_xy[v2].x), int64_t(win_xy[v2].y), win_zw[v2]);
        tri_info[start].y = sw ? -2 : -1;
        return;
    }
    int m = clip_polygon(clip[v0], clip[v1], clip[v2], params[16], params[17]);
    int64_t x0, y0, x1, y1, x2, y2;
    dvec2 zw0, zw1, zw2;
    window_of(poly_c[0], x0, y0, zw0);
    for (int j = 0; j < m - 2; j++) {
        int t = start + j;
        int b = clip_offsets[f] + j;
        window_of(poly_c[j + 1], x1, y1, zw1);
        window_of(poly_c[j + 2], x2, y2, zw2);
        bool sw = emit(t, f, x0, y0, zw0, x1, y1, zw1, x2, y2, zw2);
        int i1 = sw ? j + 2 : j + 1;
        int i2 = sw ? j + 1 : j + 2;
        for (int k = 0; k < 3; k++) {
            bary[9 * b + k] = poly_b[0][k];
            bary[9 * b + 3 + k] = poly_b[i1][k];
            bary[9 * b + 6 + k] = poly_b[i2][k];
        }
        tri_info[t].y = b;
    }
}
