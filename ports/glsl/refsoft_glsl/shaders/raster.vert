// The exact raster draws, for each clip triangle, the rectangle of its pixel box (two
// triangles, corners on pixel edges, so every pixel centre of the box is strictly inside it):
// GL only orders the fragments and keeps the depth buffer; coverage and depth are the
// fragment shader's (raster.frag), refsoft's integer edge functions.
layout(std430, binding = 0) readonly buffer TriInfo { ivec4 tri_info[]; };
layout(std430, binding = 1) readonly buffer TriBox { ivec4 tri_box[]; };

uniform int width;
uniform int height;
flat out int v_t;

const ivec2 CORNER[6] = ivec2[6](ivec2(0, 0), ivec2(1, 0), ivec2(1, 1), ivec2(0, 0), ivec2(1, 1), ivec2(0, 1));

void main() {
    int t = gl_VertexID / 6;
    ivec2 k = CORNER[gl_VertexID % 6];
    v_t = t;
    if (tri_info[t].z == 0) {
        gl_Position = vec4(-2.0, -2.0, 0.0, 1.0);   // nothing to draw: a point-sized triangle off screen
        return;
    }
    ivec4 b = tri_box[t];                          // col0, col1, row0, row1 (rows from the top)
    float x = float(k.x == 0 ? b.x : b.y + 1);
    float y = float(k.y == 0 ? height - 1 - b.w : height - b.z);   // GL window y, up
    gl_Position = vec4(2.0 * x / float(width) - 1.0, 2.0 * y / float(height) - 1.0, 0.0, 1.0);
}
