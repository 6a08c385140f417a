// The bounding box of reflector k's stencil in the main view (the pixels where it is the
// visible object), one work group: rows box[0]..box[1] - 1, cols box[2]..box[3] - 1, then
// box[4] = 1 when the stencil is not empty.
#include "common.glsl"

layout(std430, binding = 0) readonly buffer ViewId { int view_id[]; };
layout(std430, binding = 1) writeonly buffer Box { int box[]; };

uniform int width;
uniform int height;
uniform int reflector;
shared int s_box[4];

void main() {
    uint lid = gl_LocalInvocationID.x;
    if (lid == 0u) { s_box[0] = height; s_box[1] = -1; s_box[2] = width; s_box[3] = -1; }
    barrier();
    int r0 = height, r1 = -1, c0 = width, c1 = -1;
    for (int p = int(lid); p < width * height; p += GROUP) {
        if (view_id[p] == reflector) {
            int r = p / width, c = p % width;
            r0 = min(r0, r); r1 = max(r1, r); c0 = min(c0, c); c1 = max(c1, c);
        }
    }
    atomicMin(s_box[0], r0); atomicMax(s_box[1], r1); atomicMin(s_box[2], c0); atomicMax(s_box[3], c1);
    barrier();
    if (lid == 0u) {
        bool any = s_box[1] >= 0;
        box[0] = any ? s_box[0] : 0;
        box[1] = any ? s_box[1] + 1 : 0;
        box[2] = any ? s_box[2] : 0;
        box[3] = any ? s_box[3] + 1 : 0;
        box[4] = any ? 1 : 0;
    }
}
