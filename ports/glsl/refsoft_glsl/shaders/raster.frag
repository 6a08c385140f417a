// Coverage and depth of clip triangle v_t at this pixel, as refsoft's raster_tiles: biased
// 64-bit edge functions at the centre (covered when all three are >= 0), window depth
// ((e0 z0 + e1 z1) + e2 z2) * (1 / area) in float64, clamped to [0, 1] and rounded to float32;
// the float32 depth buffer and GL's in-order fragments give LESS with the first drawn winning.
// Depth peeling (use_peel): only fragments strictly behind the previous layer's depth (rows from
// the top) are kept. The depth is also written to colour attachment 1 (the peeling raster's).
layout(std430, binding = 2) readonly buffer TriXY { ivec2 tri_xy[]; };
layout(std430, binding = 3) readonly buffer TriZW { dvec2 tri_zw[]; };
layout(std430, binding = 4) readonly buffer TriEdge { i64vec4 tri_edge[]; };
layout(std430, binding = 5) readonly buffer Peel { float peel[]; };   // (H, W)

uniform bool use_peel;
uniform int width;
uniform int height;

flat in int v_t;
layout(location = 0) out int o_index;
layout(location = 1) out float o_depth;

void main() {
    int t = v_t;
    int64_t px = int64_t(int(gl_FragCoord.x)) * 256l + 128l;
    int64_t py = int64_t(int(gl_FragCoord.y)) * 256l + 128l;
    int64_t x0 = int64_t(tri_xy[3 * t].x), y0 = int64_t(tri_xy[3 * t].y);
    int64_t x1 = int64_t(tri_xy[3 * t + 1].x), y1 = int64_t(tri_xy[3 * t + 1].y);
    int64_t x2 = int64_t(tri_xy[3 * t + 2].x), y2 = int64_t(tri_xy[3 * t + 2].y);
    i64vec4 e = tri_edge[t];
    int64_t e0 = (x2 - x1) * (py - y1) - (y2 - y1) * (px - x1);
    int64_t e1 = (x0 - x2) * (py - y2) - (y0 - y2) * (px - x2);
    int64_t e2 = (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0);
    if (e0 + e.x < 0l || e1 + e.y < 0l || e2 + e.z < 0l) discard;
    precise double inv_area = 1.0lf / double(e.w);
    precise double z = ((double(e0) * tri_zw[3 * t].x + double(e1) * tri_zw[3 * t + 1].x)
                        + double(e2) * tri_zw[3 * t + 2].x) * inv_area;
    float zf = float(min(max(z, 0.0lf), 1.0lf));
    if (use_peel && !(zf > peel[(height - 1 - int(gl_FragCoord.y)) * width + int(gl_FragCoord.x)])) discard;
    gl_FragDepth = zf;
    o_index = t + 1;
    o_depth = zf;
}
