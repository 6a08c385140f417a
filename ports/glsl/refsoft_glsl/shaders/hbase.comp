// The ray-cone hierarchy's level 0 (refsoft/search/_hierarchy.py ``base_level``), one invocation
// per texel of the size x size base: a covered pixel of the crop (rows r0.., cols c0.., h x w) is
// a sphere (P, radius 0) and a cone (the reflected eye ray I - 2 (N.I) N, I = -U, half-angle 0);
// any other texel has radius and angle -1.
#include "common.glsl"
#include "hmath.glsl"

layout(std430, binding = 0) readonly buffer GP { float gp[]; };
layout(std430, binding = 1) readonly buffer GN { float gn[]; };
layout(std430, binding = 2) readonly buffer GM { int gmask[]; };
layout(std430, binding = 5) readonly buffer Params { double params[]; };   // origin 18..20, eye 21..23
layout(std430, binding = 6) writeonly buffer Sph { vec4 sph[]; };
layout(std430, binding = 7) writeonly buffer Cone { vec4 cone[]; };

uniform int size;
uniform int gwidth;
uniform ivec4 crop;   // r0, c0, h, w

void main() {
    uint iu = gid();
    if (iu >= uint(size * size)) return;
    int t = int(iu);
    int r = t / size, c = t % size;
    if (r >= crop.z || c >= crop.w || gmask[(r + crop.x) * gwidth + c + crop.y] == 0) {
        sph[t] = vec4(-1.0);
        cone[t] = vec4(-1.0);
        return;
    }
    int p = 3 * ((r + crop.x) * gwidth + c + crop.y);
    float px = gp[p], py = gp[p + 1], pz = gp[p + 2];
    float nx = gn[p], ny = gn[p + 1], nz = gn[p + 2];
    precise float ex = float(params[21] - params[18]) - px;
    precise float ey = float(params[22] - params[19]) - py;
    precise float ez = float(params[23] - params[20]) - pz;
    precise float len = sqrt((ex * ex + ey * ey) + ez * ez);
    precise float q = 1.0 / len;
    precise float ix = -(ex * q), iy = -(ey * q), iz = -(ez * q);
    if (!(len > 0.0)) { ix = -0.0; iy = -0.0; iz = -0.0; }
    precise float k = 2.0 * ((nx * ix + ny * iy) + nz * iz);
    precise float dx = ix - k * nx, dy = iy - k * ny, dz = iz - k * nz;
    sph[t] = vec4(px, py, pz, 0.0);
    cone[t] = vec4(dx, dy, dz, 0.0);
}
