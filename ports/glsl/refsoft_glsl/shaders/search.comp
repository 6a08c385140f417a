// The vertex search (spec section 4; refsoft/search/_lanes.py), one invocation per vertex:
// the walk from the coherent start (the previous pixel when still covered, else the default
// start and RESTARTED), candidates in the fixed order (current, left, up, right, down, then
// up-left, up-right, down-right, down-left for the box), moving only to a strictly larger
// score, at most ``cap`` neighbourhoods; HIDDEN at the end of the first walk, then with
// ``inverse_search`` the inverse walk from there; BORDER, CAPPED; score and margin.
#include "common.glsl"
#include "score.glsl"

layout(std430, binding = 3) readonly buffer Start { int start[]; };
layout(std430, binding = 4) readonly buffer Vertices { double vertices[]; };   // (N, 3) world
layout(std430, binding = 5) readonly buffer Params { double params[]; };       // origin 18..20, eye 21..23
layout(std430, binding = 6) readonly buffer Previous { ivec2 previous[]; };    // (N,), (-1, -1) none
layout(std430, binding = 7) writeonly buffer OutPixel { ivec2 out_pixel[]; };
layout(std430, binding = 8) writeonly buffer OutScore { REAL out_score[]; };
layout(std430, binding = 9) writeonly buffer OutMargin { REAL out_margin[]; };
layout(std430, binding = 10) writeonly buffer OutIt { int out_iterations[]; };
layout(std430, binding = 11) writeonly buffer OutFlags { uint out_flags[]; };

uniform int n;
uniform int cap;
uniform bool has_previous;
uniform bool inverse_search;

const uint HIDDEN = 1u, BORDER = 2u, CAPPED = 4u, RESTARTED = 8u, CULLED = 16u;
const ivec2 OFFSETS[9] = ivec2[9](ivec2(0, 0), ivec2(0, -1), ivec2(-1, 0), ivec2(0, 1), ivec2(1, 0),
                                  ivec2(-1, -1), ivec2(-1, 1), ivec2(1, 1), ivec2(1, -1));
const REAL NO_SCORE = REAL(-3.0);
const REAL LONE_MARGIN = REAL(2.0);

void main() {
    uint iu = gid();
    if (iu >= uint(n)) return;
    int i = int(iu);
    if (start[2] == 0) {   // nothing covered: no search
        out_pixel[i] = ivec2(-1, -1);
        out_score[i] = REAL(0.0);
        out_margin[i] = REAL(0.0);
        out_iterations[i] = 0;
        out_flags[i] = CULLED;
        return;
    }
    precise double dvx = vertices[3 * i] - params[18];
    precise double dvy = vertices[3 * i + 1] - params[19];
    precise double dvz = vertices[3 * i + 2] - params[20];
    VEC3 v = VEC3(REAL(dvx), REAL(dvy), REAL(dvz));
    precise double dex = params[21] - params[18];
    precise double dey = params[22] - params[19];
    precise double dez = params[23] - params[20];
    VEC3 e = VEC3(REAL(dex), REAL(dey), REAL(dez));
    uint fl = 0u;
    int r = start[0], c = start[1];
    if (has_previous) {
        ivec2 q = previous[i];
        bool inside = q.x >= 0 && q.x < gheight && q.y >= 0 && q.y < gwidth;   // else: the buffer changed size
        if (inside && gmask[q.x * gwidth + q.y] != 0) { r = q.x; c = q.y; }
        else if (inside) fl = RESTARTED;
    }
    bool inverse = false;
    int total = 0;
    int it = 0;
    REAL s0 = score_at(r, c, e, v, false);
    while (true) {
        it++;
        REAL best = s0, second = NO_SCORE;
        int best_k = 0;
        bool border = false;
        for (int k = 1; k < NB; k++) {
            int rr = r + OFFSETS[k].x, cc = c + OFFSETS[k].y;
            if (!covered(rr, cc)) { border = true; continue; }
            REAL sc = score_at(rr, cc, e, v, inverse);
            if (sc > best) { second = best; best = sc; best_k = k; }   // strictly larger: ties never move
            else if (sc > second) second = sc;
        }
        if (best_k != 0 && it < cap) {
            s0 = best;
            r += OFFSETS[best_k].x;
            c += OFFSETS[best_k].y;
            continue;
        }
        precise REAL res_s, res_m;
        if (best_k == 0) {
            res_s = best;
            res_m = second > NO_SCORE ? best - second : LONE_MARGIN;
        } else {   // capped: the last pixel whose neighbourhood was evaluated
            res_s = s0;
            res_m = best - s0;
            fl |= CAPPED;
        }
        total += it;
        if (!inverse) {
            int p = 3 * (r * gwidth + c);
            precise REAL dx = v.x - gp[p], dy = v.y - gp[p + 1], dz = v.z - gp[p + 2];
            REAL d = dot_exact(VEC3(dx, dy, dz), VEC3(gn[p], gn[p + 1], gn[p + 2]));
            if (d < REAL(0.0)) {
                fl |= HIDDEN;
                if (inverse_search) {
                    inverse = true;
                    it = 0;
                    s0 = score_at(r, c, e, v, true);
                    continue;
                }
            }
        }
        if (border) fl |= BORDER;
        out_pixel[i] = ivec2(r, c);
        out_score[i] = res_s;
        out_margin[i] = res_m;
        out_iterations[i] = total;
        out_flags[i] = fl;
        return;
    }
}
