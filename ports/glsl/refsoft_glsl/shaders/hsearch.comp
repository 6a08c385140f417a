// The ray-cone hierarchy search (refsoft/search/_hierarchy.py ``traverse`` and ``search_all``),
// one invocation per vertex: the pyramid top-down with a stack, every branch whose enlarged cone
// contains the vertex followed (children top-left, top-right, bottom-left, bottom-right), the
// covered base pixels under each level-1 texel reached scored, the best kept (the first of
// equal scores); restarts with enlarged cones and spheres; CAPPED at the start pixel when none
// is found. Then HIDDEN and BORDER (crosshair) and, with ``inverse_search``, the inverse
// crosshair walk. Coordinates in the crop (rows r0.., cols c0..) while traversing.
#include "common.glsl"
#include "score.glsl"
#include "hmath.glsl"

layout(std430, binding = 3) readonly buffer Start { int start[]; };
layout(std430, binding = 4) readonly buffer Vertices { double vertices[]; };
layout(std430, binding = 5) readonly buffer Params { double params[]; };
layout(std430, binding = 6) readonly buffer Sph { vec4 sph[]; };
layout(std430, binding = 7) readonly buffer Cone { vec4 cone[]; };
layout(std430, binding = 8) writeonly buffer OutPixel { ivec2 out_pixel[]; };
layout(std430, binding = 9) writeonly buffer OutScore { float out_score[]; };
layout(std430, binding = 10) writeonly buffer OutMargin { float out_margin[]; };
layout(std430, binding = 11) writeonly buffer OutIt { int out_iterations[]; };
layout(std430, binding = 12) writeonly buffer OutFlags { uint out_flags[]; };
layout(std430, binding = 13) readonly buffer Levels { int offsets[16]; int sizes[16]; };

uniform int n;
uniform int cap;
uniform bool inverse_search;
uniform ivec4 crop;   // r0, c0, h, w
uniform float cone_factor;
uniform float sphere_factor;

const uint HIDDEN = 1u, BORDER = 2u, CAPPED = 4u;
const ivec2 OFFSETS[5] = ivec2[5](ivec2(0, 0), ivec2(0, -1), ivec2(-1, 0), ivec2(0, 1), ivec2(1, 0));
const float NO_SCORE = -3.0;
const float LONE_MARGIN = 2.0;
const int MAX_ENLARGEMENTS = 8;

bool contains(vec4 s, vec4 cn, vec3 v, float kc, float ks) {
    if (cn.w < 0.0) return false;
    precise float r = s.w * ks;
    precise float wx = v.x - s.x, wy = v.y - s.y, wz = v.z - s.z;
    float dist = norm3(wx, wy, wz);
    if (dist <= r) return true;
    precise float cx = wy * cn.z - wz * cn.y;
    precise float cy = wz * cn.x - wx * cn.z;
    precise float cz = wx * cn.y - wy * cn.x;
    precise float d = (wx * cn.x + wy * cn.y) + wz * cn.z;
    float ang = atan2_f32(norm3(cx, cy, cz), d);
    precise float a = min(cn.w * kc, float(D_PI));
    precise float q = r / dist;
    precise float lim = a + asin_f32(min(q, 1.0));
    return ang <= lim;
}

void main() {
    uint iu = gid();
    if (iu >= uint(n)) return;
    int i = int(iu);
    if (start[2] == 0) {
        out_pixel[i] = ivec2(-1, -1);
        out_score[i] = 0.0;
        out_margin[i] = 0.0;
        out_iterations[i] = 0;
        out_flags[i] = 16u;
        return;
    }
    precise double dvx = vertices[3 * i] - params[18];
    precise double dvy = vertices[3 * i + 1] - params[19];
    precise double dvz = vertices[3 * i + 2] - params[20];
    vec3 v = vec3(float(dvx), float(dvy), float(dvz));
    precise double dex = params[21] - params[18];
    precise double dey = params[22] - params[19];
    precise double dez = params[23] - params[20];
    vec3 e = vec3(float(dex), float(dey), float(dez));

    ivec3 stack[3 * NLEV + 4];
    int tests = 0;
    precise float kc = 1.0, ks = 1.0;
    int br = -1, bc = -1;
    bool found = false;
    for (int attempt = 0; attempt <= MAX_ENLARGEMENTS; attempt++) {
        float best = NO_SCORE;
        br = -1; bc = -1;
        stack[0] = ivec3(NLEV - 1, 0, 0);
        int sp = 1;
        while (sp > 0) {
            sp--;
            ivec3 top = stack[sp];
            int lvl = top.x, ti = top.y, tj = top.z;
            if (lvl <= 1) {
                int side = 1 << lvl, base = sizes[0];
                for (int r = ti * side; r < (ti + 1) * side; r++) {
                    for (int c = tj * side; c < (tj + 1) * side; c++) {
                        if (cone[offsets[0] + r * base + c].w < 0.0) continue;
                        float sc = score_at(r + crop.x, c + crop.y, e, v, false);
                        tests++;
                        if (sc > best) { best = sc; br = r; bc = c; }
                    }
                }
                continue;
            }
            int child = lvl - 1, cs = sizes[child];
            for (int k = 3; k >= 0; k--) {
                int ci = 2 * ti + k / 2, cj = 2 * tj + k % 2;
                int q = offsets[child] + ci * cs + cj;
                tests++;
                if (contains(sph[q], cone[q], v, kc, ks)) {
                    stack[sp] = ivec3(child, ci, cj);
                    sp++;
                }
            }
            if (tests >= cap) break;
        }
        if (br >= 0) { found = true; break; }
        if (tests >= cap) break;
        kc = kc * cone_factor;
        ks = ks * sphere_factor;
    }
    int r, c;
    if (found) { r = br + crop.x; c = bc + crop.y; }
    else { r = start[0]; c = start[1]; }
    float s = score_at(r, c, e, v, false);
    float m = LONE_MARGIN;
    uint fl = found ? 0u : CAPPED;
    bool border = false;
    for (int k = 1; k < 5; k++) {
        if (!covered(r + OFFSETS[k].x, c + OFFSETS[k].y)) border = true;
    }
    int p = 3 * (r * gwidth + c);
    precise float hx = v.x - gp[p], hy = v.y - gp[p + 1], hz = v.z - gp[p + 2];
    float d = dot_exact(vec3(hx, hy, hz), vec3(gn[p], gn[p + 1], gn[p + 2]));
    bool hidden = d < 0.0;
    if (hidden) fl |= HIDDEN;
    if (hidden && inverse_search) {
        // the inverse crosshair walk from here (spec section 4.6)
        int it = 0;
        float s0 = score_at(r, c, e, v, true);
        while (true) {
            it++;
            float b = s0, second = NO_SCORE;
            int bk = 0;
            border = false;
            for (int k = 1; k < 5; k++) {
                int rr = r + OFFSETS[k].x, cc = c + OFFSETS[k].y;
                if (!covered(rr, cc)) { border = true; continue; }
                float sc = score_at(rr, cc, e, v, true);
                if (sc > b) { second = b; b = sc; bk = k; }
                else if (sc > second) second = sc;
            }
            if (bk != 0 && it < cap) {
                s0 = b;
                r += OFFSETS[bk].x;
                c += OFFSETS[bk].y;
                continue;
            }
            precise float rs, rm;
            if (bk == 0) {
                rs = b;
                rm = second > NO_SCORE ? b - second : LONE_MARGIN;
            } else {
                rs = s0;
                rm = b - s0;
                fl |= CAPPED;
            }
            s = rs; m = rm;
            tests += it;
            break;
        }
    }
    if (border) fl |= BORDER;
    out_pixel[i] = ivec2(r, c);
    out_score[i] = s;
    out_margin[i] = m;
    out_iterations[i] = tests;
    out_flags[i] = fl;
}
