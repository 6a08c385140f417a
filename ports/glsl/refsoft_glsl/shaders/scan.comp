// Exclusive prefix sum of n ints into n + 1 (the total last), in three passes over blocks of
// GROUP * PER ints: PHASE 0 block totals, PHASE 1 their scan (one invocation), PHASE 2 the
// output. Integer sums: the result does not depend on the order.
#include "common.glsl"

const int PER = 16;
layout(std430, binding = 0) readonly buffer In { int values[]; };
layout(std430, binding = 1) buffer Blocks { int blocks[]; };
layout(std430, binding = 2) writeonly buffer Out { int prefix[]; };

uniform int n;
shared int partial[GROUP];

void main() {
#if PHASE == 1
    if (gl_GlobalInvocationID.x != 0u) return;
    int nb = (n + GROUP * PER - 1) / (GROUP * PER);
    int total = 0;
    for (int b = 0; b < nb; b++) {
        int v = blocks[b];
        blocks[b] = total;
        total += v;
    }
    prefix[n] = total;
#else
    uint block = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    uint lid = gl_LocalInvocationID.x;
    int first = int(block) * GROUP * PER + int(lid) * PER;
    int sum = 0;
    for (int k = 0; k < PER; k++) {
        int j = first + k;
        if (j < n) sum += values[j];
    }
    partial[lid] = sum;
    barrier();
    if (lid == 0u) {
        int run = 0;
        for (int t = 0; t < GROUP; t++) {
            int v = partial[t];
            partial[t] = run;
            run += v;
        }
#if PHASE == 0
        blocks[block] = run;
#endif
    }
    barrier();
#if PHASE == 2
    int run = blocks[block] + partial[lid];
    for (int k = 0; k < PER; k++) {
        int j = first + k;
        if (j < n) {
            prefix[j] = run;
            run += values[j];
        }
    }
#endif
#endif
}
