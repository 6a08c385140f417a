"""The per-pixel LDT search as one Numba kernel, parallel over reflector pixels (docs/ldt.md, "The
per-pixel search"; the order of operations is the contract's, step for step).

Every kernel works in the precision of the scalar ``fp`` (``np.float32(0)`` or ``np.float64(0)``):
the ray, the cube coordinates, the texel coordinates, the depths compared (the stored float32
depths are widened exactly in float64) and the residuals. Each pixel writes only its own
outputs, so the result does not depend on the thread count. ``tests/naive.py``'s
``naive_ldt_pixel`` is the plain reference.
"""

import numpy as np

from .._numba import kernel, like
from .constants import (LAYER_MISMATCH, NO_FACE_WITHIN_TAU, OPEN_OBJECT, ORIGIN_IN_CUBE, REGION_CULLED,
                        START_INSIDE)


@kernel(inline=True)
def _pick(x, y, z, axis):
    if axis == 0:
        return x
    if axis == 1:
        return y
    return z


@kernel(inline=True)
def _int_margin(x, Rf, fp):
    """Distance of ``x`` (texel units) from the nearest integer strictly inside (0, R), where
    the texel index changes; 1 when that integer is 0 or R (clamped: nothing changes)."""
    k = np.floor(x + like(0.5, fp))
    if k > like(0.0, fp) and k < Rf:
        return abs(x - k)
    return like(1.0, fp)


@kernel
def _texel(q0x, q0y, q0z, ux, uy, uz, s, f, table, R, fp):
    """Face ``f``'s texel and axial depth at ``q(s) = q0 + s u``: (row, col, h, margin of the
    texel coordinates from an interior integer)."""
    half = like(0.5, fp)
    one = like(1.0, fp)
    Rf = like(R, fp)
    qx = q0x + s * ux
    qy = q0y + s * uy
    qz = q0z + s * uz
    sc = _pick(qx, qy, qz, table[f, 0])
    if table[f, 1] < 0:
        sc = -sc
    tc = _pick(qx, qy, qz, table[f, 2])
    if table[f, 3] < 0:
        tc = -tc
    x = ((sc + one) * half) * Rf
    y = ((tc + one) * half) * Rf
    col = min(max(int(np.floor(x)), 0), R - 1)
    row = R - 1 - min(max(int(np.floor(y)), 0), R - 1)
    qa = _pick(qx, qy, qz, f // 2)
    h = half * (one - qa) if f % 2 == 0 else half * (one + qa)
    return row, col, h, min(_int_margin(x, Rf, fp), _int_margin(y, Rf, fp))


@kernel
def _face_search(q0x, q0y, q0z, ux, uy, uz, s_in, s_out, umax, n_lin, f, k, depth, back, count, is_open, table, R,
                 fp):
    """Linear search then bisection of one face (Algorithm 1 with the full interval test).

    An open object (``is_open``: one layer, ``back = 1``) is searched by the crossing rule: a
    sample at or behind the sheet (``h >= z``) is inside only when the sample before it lay in
    front of the sheet (``h < z`` at that sample's own texel, which holds the sheet); so the
    first sample is never inside, and a ray that starts behind the sheet is outside until it
    comes in front of it and crosses again.

    Returns (found, s_hit, layer, row, col, residual in texels, samples, bisection steps, margin,
    started inside)."""
    one = like(1.0, fp)
    half = like(0.5, fp)
    Rf = like(R, fp)
    if n_lin > 0:
        n = n_lin
    else:  # "texel": at most one texel (Chebyshev) per step
        n = int(np.ceil(((umax * (s_out - s_in)) * Rf) * half))
        n = min(max(n, 1), 4 * R)
    D = (s_out - s_in) / like(n, fp)
    margin = like(1.0, fp)
    found_j = -1
    m = 0
    row = col = 0
    h = like(0.0, fp)
    sheet = is_open[k]
    in_front = False  # an open object: the previous sample lay in front of the sheet
    for m in range(n + 1):
        sm = s_in + like(m, fp) * D
        row, col, h, mt = _texel(q0x, q0y, q0z, ux, uy, uz, sm, f, table, R, fp)
        margin = min(margin, mt)
        front = False
        for j in range(np.int64(count[k, f, row, col])):  # int64: uint8 and int64 would unify to float
            z = like(depth[k, f, j, row, col], fp)
            margin = min(margin, abs(h - z))
            if h < z:
                front = True
                break
            d = back[k, f, j, row, col]
            margin = min(margin, abs(h - d))
            if h <= d:
                if in_front or not sheet:
                    found_j = j
                break
        if found_j >= 0:
            break
        in_front = front
    samples = m + 1
    if found_j < 0:
        return False, like(0.0, fp), -1, 0, 0, like(0.0, fp), samples, 0, margin, False
    j = found_j
    if m == 0:
        e = (h - like(depth[k, f, j, row, col], fp)) * Rf
        return True, s_in, j, row, col, e, samples, 0, margin, True
    lo = s_in + like(m - 1, fp) * D
    hi = s_in + like(m, fp) * D
    length = ((D * umax) * Rf) * half
    steps = 0
    while length > like(0.125, fp) and steps < 16:
        length = length * half
        steps += 1
    row_hi, col_hi, h_hi = row, col, h
    for _ in range(steps):
        mid = half * (lo + hi)
        r, c, hm, mt = _texel(q0x, q0y, q0z, ux, uy, uz, mid, f, table, R, fp)
        margin = min(margin, mt)
        inside = False
        if j < np.int64(count[k, f, r, c]):
            z = like(depth[k, f, j, r, c], fp)
            d = back[k, f, j, r, c]
            margin = min(margin, min(abs(hm - z), abs(hm - d)))
            inside = z <= hm and hm <= d
        if inside:
            hi = mid
            row_hi, col_hi, h_hi = r, c, hm
        else:
            lo = mid
    e = (h_hi - like(depth[k, f, j, row_hi, col_hi], fp)) * Rf
    return True, hi, j, row_hi, col_hi, e, samples, steps, margin, False


@kernel
def search_pixels(lo, hi, P, N, eye, ortho, view_dir, tri, region, use_regions, W, depth, back, count, mismatch,
                  is_open, table, R, n_lin, tau, max_faces, fp,
                  ray, t_out, obj_out, face_out, layer_out, texel_out, residual_out, samples_out, steps_out,
                  faces_out, objects_out, flags_out, obj_dist, margin_out, hit_out):
    """The LDT search of every pixel ``i`` in ``lo .. hi - 1`` (rows of ``P``, ``N``; run over every
    pixel by :func:`refsoft._parallel.parallel_range`): see :func:`refsoft.ldt.search.search` for
    the arrays. ``n_lin`` 0 means "texel"; ``max_faces`` 3 or 1 (the entry face only)."""
    K = W.shape[0]
    zero = like(0.0, fp)
    one = like(1.0, fp)
    two = like(2.0, fp)
    inf = like(np.inf, fp)
    for i in range(lo, hi):
        px, py, pz = P[i, 0], P[i, 1], P[i, 2]
        if ortho:
            ix, iy, iz = view_dir[0], view_dir[1], view_dir[2]
        else:
            dx, dy, dz = px - eye[0], py - eye[1], pz - eye[2]
            length = np.sqrt((dx * dx + dy * dy) + dz * dz)
            ix, iy, iz = dx / length, dy / length, dz / length
        nx, ny, nz = N[i, 0], N[i, 1], N[i, 2]
        kk = two * ((nx * ix + ny * iy) + nz * iz)
        rx, ry, rz = ix - kk * nx, iy - kk * ny, iz - kk * nz
        ray[i, 0], ray[i, 1], ray[i, 2] = rx, ry, rz
        flags = 0
        best_t = inf
        best_k = -1
        best_f = best_j = best_r = best_c = -1
        best_e = zero
        best_m = zero
        best_flags = 0
        any_margin = one  # the smallest comparison of every search, for pixels with no hit
        samples = steps = faces = objects = 0
        for k in range(K):
            obj_dist[i, k] = -one
            q0x = ((W[k, 0, 0] * px + W[k, 0, 1] * py) + W[k, 0, 2] * pz) + W[k, 0, 3]
            q0y = ((W[k, 1, 0] * px + W[k, 1, 1] * py) + W[k, 1, 2] * pz) + W[k, 1, 3]
            q0z = ((W[k, 2, 0] * px + W[k, 2, 1] * py) + W[k, 2, 2] * pz) + W[k, 2, 3]
            ux = (W[k, 0, 0] * rx + W[k, 0, 1] * ry) + W[k, 0, 2] * rz
            uy = (W[k, 1, 0] * rx + W[k, 1, 1] * ry) + W[k, 1, 2] * rz
            uz = (W[k, 2, 0] * rx + W[k, 2, 1] * ry) + W[k, 2, 2] * rz
            # slab clip against [-1, 1]^3
            near = -inf
            far = inf
            entry = -1
            miss = False
            for a in range(3):
                qa = _pick(q0x, q0y, q0z, a)
                ua = _pick(ux, uy, uz, a)
                if ua == zero:
                    if abs(qa) > one:
                        miss = True
                    continue
                s_lo = (-one - qa) / ua
                s_hi = (one - qa) / ua
                if s_hi < s_lo:
                    s_lo, s_hi = s_hi, s_lo
                if s_lo > near:  # ties keep the smaller axis
                    near = s_lo
                    entry = a
                far = min(far, s_hi)
            s_in = max(zero, near)
            if miss or entry < 0 or not s_in < far:
                continue
            if use_regions and not region[tri[i], k]:
                flags |= REGION_CULLED
                continue
            objects += 1
            if not near > zero:
                flags |= ORIGIN_IN_CUBE
                entry = -1
            s_out = far
            aux, auy, auz = abs(ux), abs(uy), abs(uz)
            umax = max(aux, max(auy, auz))
            # faces: the entry face, then decreasing |u_i| (ties: smaller axis); u_i == 0 never
            order = np.empty(3, dtype=np.int64)
            n_order = 0
            if entry >= 0:
                order[0] = entry
                n_order = 1
            for _ in range(3):
                pick = -1
                best_u = zero
                for a in range(3):
                    taken = False
                    for b in range(n_order):
                        if order[b] == a:
                            taken = True
                    ua = _pick(aux, auy, auz, a)
                    if not taken and ua > best_u:
                        pick = a
                        best_u = ua
                if pick < 0:
                    break
                order[n_order] = pick
                n_order += 1
            n_order = min(n_order, max_faces)
            got = False
            cand_e = inf
            cand = (False, zero, -1, 0, 0, zero, 0, 0, zero, False)
            cand_f = -1
            accepted = False
            for b in range(n_order):
                a = order[b]
                ua = _pick(ux, uy, uz, a)
                f = 2 * a + (1 if ua > zero else 0)
                res = _face_search(q0x, q0y, q0z, ux, uy, uz, s_in, s_out, umax, n_lin, f, k, depth, back, count,
                                   is_open, table, R, fp)
                faces += 1
                samples += res[6]
                steps += res[7]
                any_margin = min(any_margin, res[8])
                if not res[0]:
                    continue
                if res[5] <= tau:
                    cand, cand_f, got, accepted = res, f, True, True
                    break
                if res[5] < cand_e:
                    cand_e = res[5]
                    cand, cand_f, got = res, f, True
            if not got:
                continue
            t_k = cand[1]
            obj_dist[i, k] = t_k
            if t_k < best_t:
                best_t = t_k
                best_k = k
                best_f, best_j, best_r, best_c = cand_f, cand[2], cand[3], cand[4]
                best_e = cand[5]
                best_m = cand[8]
                best_flags = (START_INSIDE if cand[9] else 0) | (0 if accepted else NO_FACE_WITHIN_TAU)
        samples_out[i] = samples
        steps_out[i] = steps
        # int8 outputs: saturate (more than 42 objects searched on three faces would wrap around)
        faces_out[i] = min(faces, 127)
        objects_out[i] = min(objects, 127)
        if best_k < 0:
            t_out[i] = -one
            obj_out[i] = -1
            face_out[i] = -1
            layer_out[i] = -1
            texel_out[i, 0] = -1
            texel_out[i, 1] = -1
            residual_out[i] = zero
            margin_out[i] = any_margin
            flags_out[i] = flags
            hit_out[i, 0], hit_out[i, 1], hit_out[i, 2] = zero, zero, zero
            continue
        if mismatch[best_k, best_f, best_r, best_c]:
            best_flags |= LAYER_MISMATCH
        if is_open[best_k]:
            best_flags |= OPEN_OBJECT
        t_out[i] = best_t
        obj_out[i] = best_k
        face_out[i] = best_f
        layer_out[i] = best_j
        texel_out[i, 0] = best_r
        texel_out[i, 1] = best_c
        residual_out[i] = best_e
        margin_out[i] = best_m
        flags_out[i] = flags | best_flags
        hit_out[i, 0] = px + best_t * rx
        hit_out[i, 1] = py + best_t * ry
        hit_out[i, 2] = pz + best_t * rz
