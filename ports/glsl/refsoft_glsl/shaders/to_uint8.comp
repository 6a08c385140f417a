// 8 bits (spec section 5): round(clip(c, 0, 1) * 255) in float64, half to even; NaN gives 0.
#include "common.glsl"

layout(std430, binding = 0) readonly buffer Colour { float colour[]; };
layout(std430, binding = 1) writeonly buffer Image { uint image[]; };   // 4 channels word per uint

uniform int n;   // channels, a multiple of 4 is not needed

void main() {
    uint q = gid();
    if (4u * q >= uint(n)) return;
    uint word = 0u;
    for (int j = 0; j < 4; j++) {
        int i = 4 * int(q) + j;
        uint b = 0u;
        if (i < n) {
            double x = double(colour[i]);
            precise double s = x * 255.0lf;
            if (!(x > 0.0lf)) b = 0u;
            else if (x >= 1.0lf) b = 255u;
            else b = uint(roundEven(s));
        }
        word |= b << uint(8 * j);
    }
    image[q] = word;
}
