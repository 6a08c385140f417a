// Composite of reflector k (spec section 5), in float32: on its stencil, where the virtual
// scene covers the pixel, rho * virtual colour + (1 - rho) * the reflector's colour, and the
// reflected object's id; 0 on the rest of the stencil.
#include "common.glsl"

layout(std430, binding = 0) readonly buffer ViewId { int view_id[]; };
layout(std430, binding = 1) readonly buffer ViewColour { float view_colour[]; };
layout(std430, binding = 2) readonly buffer VirtualColour { float vcolour[]; };
layout(std430, binding = 3) readonly buffer VirtualId { int vid[]; };
layout(std430, binding = 4) buffer Colour { float colour[]; };
layout(std430, binding = 5) buffer Reflected { int reflected[]; };

uniform int n;
uniform int reflector;
uniform float rho;

void main() {
    uint pu = gid();
    if (pu >= uint(n)) return;
    int p = int(pu);
    if (view_id[p] != reflector) return;
    int id = vid[p];
    reflected[p] = id;
    if (id == 0) return;
    precise float one_minus = 1.0 - rho;
    for (int ch = 0; ch < 3; ch++) {
        precise float c = rho * vcolour[3 * p + ch] + one_minus * view_colour[3 * p + ch];
        colour[3 * p + ch] = c;
    }
}
