// The search's start without history (spec section 4.3), one work group: the centre of the
// covered pixels' bounding box, (floor((r0 + r1) / 2), floor((c0 + c1) / 2)); if it is not
// covered, the covered pixel nearest to it (squared distance, then row, then column).
// out: row, col, 1 (0 0 0 when nothing is covered).
#include "common.glsl"

layout(std430, binding = 2) readonly buffer GM { int gmask[]; };
layout(std430, binding = 3) writeonly buffer Start { int start[]; };

uniform int gwidth;
uniform int gheight;

shared int s_box[4];
shared int s_best[GROUP * 2];
shared int s_centre[3];

void main() {
    uint lid = gl_LocalInvocationID.x;
    int n = gwidth * gheight;
    if (lid == 0u) {
        s_box[0] = gheight; s_box[1] = -1; s_box[2] = gwidth; s_box[3] = -1;
    }
    barrier();
    int r0 = gheight, r1 = -1, c0 = gwidth, c1 = -1;
    for (int p = int(lid); p < n; p += GROUP) {
        if (gmask[p] != 0) {
            int r = p / gwidth, c = p % gwidth;
            r0 = min(r0, r); r1 = max(r1, r); c0 = min(c0, c); c1 = max(c1, c);
        }
    }
    atomicMin(s_box[0], r0); atomicMax(s_box[1], r1); atomicMin(s_box[2], c0); atomicMax(s_box[3], c1);
    barrier();
    if (lid == 0u) {
        if (s_box[1] < 0) {
            s_centre[2] = 0;
        } else {
            int r = (s_box[0] + s_box[1]) / 2, c = (s_box[2] + s_box[3]) / 2;
            s_centre[0] = r; s_centre[1] = c;
            s_centre[2] = gmask[r * gwidth + c] != 0 ? 1 : 2;
        }
    }
    barrier();
    if (s_centre[2] == 2) {   // the nearest covered pixel: each invocation's own best, then the group's
        int r = s_centre[0], c = s_centre[1];
        int bd = 0x7fffffff, bp = n;
        for (int p = int(lid); p < n; p += GROUP) {
            if (gmask[p] != 0) {
                int dr = p / gwidth - r, dc = p % gwidth - c;
                int d = dr * dr + dc * dc;
                if (d < bd || (d == bd && p < bp)) { bd = d; bp = p; }
            }
        }
        s_best[2 * lid] = bd;
        s_best[2 * lid + 1] = bp;
        barrier();
        if (lid == 0u) {
            for (int t = 1; t < GROUP; t++) {
                int d = s_best[2 * t], p = s_best[2 * t + 1];
                if (d < bd || (d == bd && p < bp)) { bd = d; bp = p; }
            }
            s_centre[0] = bp / gwidth; s_centre[1] = bp % gwidth;
        }
    }
    barrier();
    if (lid == 0u) {
        bool any = s_centre[2] != 0;
        start[0] = any ? s_centre[0] : 0;
        start[1] = any ? s_centre[1] : 0;
        start[2] = any ? 1 : 0;
    }
}
