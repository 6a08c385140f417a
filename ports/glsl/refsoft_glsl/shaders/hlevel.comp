// One level of the ray-cone hierarchy from the one below (refsoft/search/_hierarchy.py
// ``next_level``): each texel bounds its 2x2 children, (top-left, top-right) and
// (bottom-left, bottom-right), then the two results, with boundSphere and boundCone.
#include "common.glsl"
#include "hmath.glsl"

layout(std430, binding = 6) buffer Sph { vec4 sph[]; };
layout(std430, binding = 7) buffer Cone { vec4 cone[]; };

uniform int size;       // of the new level
uniform int src;        // first texel of the level below
uniform int dst;        // first texel of the new level

vec4 bound_sphere(vec4 a, vec4 b) {
    if (a.w < 0.0) return b;
    if (b.w < 0.0) return a;
    precise float dx = b.x - a.x, dy = b.y - a.y, dz = b.z - a.z;
    float d = norm3(dx, dy, dz);
    precise float db = d + b.w, da = d + a.w;
    if (db <= a.w) return a;
    if (da <= b.w) return b;
    precise float s = (b.w - a.w) / d;
    precise float ox = a.x + 0.5 * (dx + dx * s);
    precise float oy = a.y + 0.5 * (dy + dy * s);
    precise float oz = a.z + 0.5 * (dz + dz * s);
    precise float orad = ((d + a.w) + b.w) * 0.5;
    return vec4(ox, oy, oz, orad);
}

vec4 bound_cone(vec4 a, vec4 b) {
    if (a.w < 0.0) return b;
    if (b.w < 0.0) return a;
    precise float sx = a.x + b.x, sy = a.y + b.y, sz = a.z + b.z;
    float n = norm3(sx, sy, sz);
    if (n == 0.0) return vec4(a.xyz, float(D_PI));
    precise float cx = a.y * b.z - a.z * b.y;
    precise float cy = a.z * b.x - a.x * b.z;
    precise float cz = a.x * b.y - a.y * b.x;
    precise float d = (a.x * b.x + a.y * b.y) + a.z * b.z;
    float ang = atan2_f32(norm3(cx, cy, cz), d);
    precise float ox = sx / n, oy = sy / n, oz = sz / n;
    precise float ow = ang * 0.5 + max(a.w, b.w);
    return vec4(ox, oy, oz, ow);
}

void main() {
    uint iu = gid();
    if (iu >= uint(size * size)) return;
    int t = int(iu);
    int i = t / size, j = t % size;
    int below = 2 * size;
    int q = src + (2 * i) * below + 2 * j;
    vec4 ta = bound_sphere(sph[q], sph[q + 1]);
    vec4 tb = bound_sphere(sph[q + below], sph[q + below + 1]);
    sph[dst + t] = bound_sphere(ta, tb);
    ta = bound_cone(cone[q], cone[q + 1]);
    tb = bound_cone(cone[q + below], cone[q + below + 1]);
    cone[dst + t] = bound_cone(ta, tb);
}
