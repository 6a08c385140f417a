// Vertex stage of the exact raster (refsoft/raster/_setup.py): clip coordinates
// ((m0 x + m1 y) + m2 z) + m3 in float64, the outcodes of the five clip planes, and for a vertex
// inside all of them its window coordinates: x, y snapped to 1/256 px (round half to even),
// z_w = 0.5 z/w + 0.5 and 1/w.
#include "common.glsl"
#include "clip.glsl"

layout(std430, binding = 0) readonly buffer Points { double points[]; };    // (V, 3)
layout(std430, binding = 1) readonly buffer Params { double params[]; };    // view_proj (16, row-major), gx, gy
layout(std430, binding = 2) writeonly buffer Clip { dvec4 clip[]; };        // (V,)
layout(std430, binding = 3) writeonly buffer Codes { uint codes[]; };
layout(std430, binding = 4) writeonly buffer WinXY { ivec2 win_xy[]; };
layout(std430, binding = 5) writeonly buffer WinZW { dvec2 win_zw[]; };

uniform int n;
uniform int width;
uniform int height;

int snap(double v) {
    precise double s = v * 256.0lf;
    return int(roundEven(s));
}

void main() {
    uint i = gid();
    if (i >= uint(n)) return;
    double x = points[3 * i], y = points[3 * i + 1], z = points[3 * i + 2];
    precise dvec4 c;
    for (int r = 0; r < 4; r++) {
        c[r] = ((params[4 * r] * x + params[4 * r + 1] * y) + params[4 * r + 2] * z) + params[4 * r + 3];
    }
    clip[i] = c;
    uint code = outcode(c, params[16], params[17]);
    codes[i] = code;
    if (code != 0u) {
        win_xy[i] = ivec2(0);
        win_zw[i] = dvec2(0.0lf);
        return;
    }
    precise double wx = (c.x / c.w + 1.0lf) * (0.5lf * double(width));
    precise double wy = (c.y / c.w + 1.0lf) * (0.5lf * double(height));
    precise double zw = 0.5lf * (c.z / c.w) + 0.5lf;
    precise double iw = 1.0lf / c.w;
    win_xy[i] = ivec2(snap(wx), snap(wy));
    win_zw[i] = dvec2(zw, iw);
}
