// The G-buffer outputs (spec section 7): world-space float32 positions (origin + P in float64,
// then rounded), zero where not covered; float32 normals.
#include "common.glsl"

layout(std430, binding = 0) readonly buffer GP { REAL gp[]; };
layout(std430, binding = 1) readonly buffer GN { REAL gn[]; };
layout(std430, binding = 2) readonly buffer GM { int gmask[]; };
layout(std430, binding = 5) readonly buffer Params { double params[]; };
layout(std430, binding = 6) writeonly buffer OutP { float out_p[]; };
layout(std430, binding = 7) writeonly buffer OutN { float out_n[]; };

uniform int n;   // pixels

void main() {
    uint pu = gid();
    if (pu >= uint(n)) return;
    int p = int(pu);
    bool m = gmask[p] != 0;
    for (int ch = 0; ch < 3; ch++) {
        precise double w = double(gp[3 * p + ch]) + params[18 + ch];
        out_p[3 * p + ch] = m ? float(w) : 0.0;
        out_n[3 * p + ch] = float(gn[3 * p + ch]);
    }
}
