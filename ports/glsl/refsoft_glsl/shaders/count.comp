// Per input triangle: how many clip triangles it gives (0 when culled by a plane, or left out
// by the flag filter), and that count again when it was clipped (0 when it passes whole).
#include "common.glsl"
#include "clip.glsl"

layout(std430, binding = 0) readonly buffer Faces { int faces[]; };          // (F, 3)
layout(std430, binding = 1) readonly buffer Clip { dvec4 clip[]; };
layout(std430, binding = 2) readonly buffer Codes { uint codes[]; };
layout(std430, binding = 3) readonly buffer Params { double params[]; };
layout(std430, binding = 4) readonly buffer Flags { uint vflags[]; };       // per vertex (filter)
layout(std430, binding = 5) writeonly buffer Counts { int counts[]; };
layout(std430, binding = 6) writeonly buffer Clipped { int clipped[]; };

uniform int n;
uniform uint bad;   // a triangle with a vertex flag in ``bad`` is left out (0: none)

void main() {
    uint f = gid();
    if (f >= uint(n)) return;
    int v0 = faces[3 * f], v1 = faces[3 * f + 1], v2 = faces[3 * f + 2];
    if (bad != 0u && ((vflags[v0] | vflags[v1] | vflags[v2]) & bad) != 0u) {
        counts[f] = 0;
        clipped[f] = 0;
        return;
    }
    uint o0 = codes[v0], o1 = codes[v1], o2 = codes[v2];
    if ((o0 | o1 | o2) == 0u) {
        counts[f] = 1;
        clipped[f] = 0;
    } else if ((o0 & o1 & o2) != 0u) {
        counts[f] = 0;
        clipped[f] = 0;
    } else {
        int m = clip_polygon(clip[v0], clip[v1], clip[v2], params[16], params[17]);
        int c = m >= 3 ? m - 2 : 0;
        counts[f] = c;
        clipped[f] = c;
    }
}
