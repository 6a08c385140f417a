// The tessellation's edge errors (refsoft/search/_tessellate.py ``edge_errors``), float64, one
// invocation per edge (e0, e1): 1 - (dot(N, b) + 1) / 2 with b the unit bisector of the
// directions from the surface point to the eye and to the edge's midpoint; the surface point at
// the midpoint of the ends' sub-texel points by the first-order model at the texel nearest to
// it (the texel halfway, rounded down, beside the outline); 1 where an end has no pixel or that
// texel is uncovered.
#include "common.glsl"
#include "score.glsl"
#include "surface.glsl"

layout(std430, binding = 4) readonly buffer Vertices { double vertices[]; };   // (V, 3) world
layout(std430, binding = 5) readonly buffer Params { double params[]; };       // origin 18..20, eye 21..23
layout(std430, binding = 7) readonly buffer Pixel { ivec2 pixel[]; };
layout(std430, binding = 8) readonly buffer Offset { REAL offset[]; };         // (V, 2)
layout(std430, binding = 9) readonly buffer Edges { ivec2 edges[]; };
layout(std430, binding = 10) writeonly buffer Out { double out_error[]; };

uniform int n;
uniform bool subtexel;   // the ends have sub-texel offsets (refine); else the texel halfway

dvec3 unit(double x, double y, double z) {
    precise double l = sqrt((x * x + y * y) + z * z);
    precise double ox = x / l, oy = y / l, oz = z / l;
    return l > 0.0lf ? dvec3(ox, oy, oz) : dvec3(0.0lf);
}

void finish(int i, int a, int b, dvec3 P, dvec3 N);

void main() {
    uint iu = gid();
    if (iu >= uint(n)) return;
    int i = int(iu);
    int a = edges[i].x, b = edges[i].y;
    out_error[i] = 1.0lf;
    ivec2 pa = pixel[a], pb = pixel[b];
    if (pa.x < 0 || pa.y < 0 || pb.x < 0 || pb.y < 0) return;
    int hr = (pa.x + pb.x) / 2, hc = (pa.y + pb.y) / 2;   // both >= 0: truncation is floor
    if (!subtexel) {
        if (!covered(hr, hc)) return;
        int q = 3 * (hr * gwidth + hc);
        finish(i, a, b, dvec3(gp[q], gp[q + 1], gp[q + 2]), dvec3(gn[q], gn[q + 1], gn[q + 2]));
        return;
    }
    precise double mr = 0.5lf * ((double(pa.x) + double(offset[2 * a])) + (double(pb.x) + double(offset[2 * b])));
    precise double mc = 0.5lf * ((double(pa.y) + double(offset[2 * a + 1])) + (double(pb.y) + double(offset[2 * b + 1])));
    precise double fr = floor(mr + 0.5lf), fc = floor(mc + 0.5lf);
    int r = int(fr), c = int(fc);
    if (!covered(r, c)) {
        r = hr;
        c = hc;
        if (!covered(r, c)) return;
    }
    precise double tr = mr - double(r), tc = mc - double(c);
    VEC3 P, N;
    surface_values(r, c, REAL(tr), REAL(tc), P, N);
    finish(i, a, b, dvec3(P), dvec3(N));
}

// the error at surface point P (relative to the origin) with unit normal N
void finish(int i, int a, int b, dvec3 P, dvec3 N) {
    precise double px = P.x + params[18], py = P.y + params[19], pz = P.z + params[20];
    double nx = N.x, ny = N.y, nz = N.z;
    precise double mx = 0.5lf * (vertices[3 * a] + vertices[3 * b]);
    precise double my = 0.5lf * (vertices[3 * a + 1] + vertices[3 * b + 1]);
    precise double mz = 0.5lf * (vertices[3 * a + 2] + vertices[3 * b + 2]);
    dvec3 v = unit(params[21] - px, params[22] - py, params[23] - pz);
    dvec3 w = unit(mx - px, my - py, mz - pz);
    precise double sx = v.x + w.x, sy = v.y + w.y, sz = v.z + w.z;
    dvec3 h = unit(sx, sy, sz);
    precise double d = (nx * h.x + ny * h.y) + nz * h.z;
    precise double e = 1.0lf - (d + 1.0lf) / 2.0lf;
    out_error[i] = e;
}
