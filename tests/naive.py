"""Slow, plainly written NumPy references for the fast kernels (same conventions, spec section 2).

Nothing here is fast or clever: one triangle at a time, whole bounding boxes evaluated with
NumPy, Python lists for clipped polygons. The fast kernels must agree with these.
"""

from __future__ import annotations

import numpy as np

GUARD_BAND_PIXELS = float(1 << 20)


def plane_distances(c, gx, gy):
    """Signed distances of a clip vertex to the 5 clip planes (near, +x, -x, +y, -y guard)."""
    x, y, z, w = c
    return [z + w, gx * w - x, gx * w + x, gy * w - y, gy * w + y]


def clip_triangle(c3, gx, gy):
    """Sutherland-Hodgman: list of (clip vertex, barycentric row) after every plane."""
    poly = [(np.array(c3[i], dtype=np.float64), np.eye(3)[i]) for i in range(3)]
    for p in range(5):
        out = []
        n = len(poly)
        for i in range(n):
            a, b = poly[i], poly[(i + 1) % n]
            da, db = plane_distances(a[0], gx, gy)[p], plane_distances(b[0], gx, gy)[p]
            if da >= 0:
                out.append(a)
            if (da >= 0) != (db >= 0):
                ins, outs, di, do = (a, b, da, db) if da >= 0 else (b, a, db, da)
                t = di / (di - do)
                out.append((ins[0] + t * (outs[0] - ins[0]), ins[1] + t * (outs[1] - ins[1])))
        poly = out
        if len(poly) < 3:
            return []
    return poly


def edge(ax, ay, bx, by, px, py):
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


def setup_triangles(clip, faces, width, height):
    """All clip triangles in draw order: dicts with snapped x, y, z, 1/w, B and the face index."""
    gx, gy = 2 * GUARD_BAND_PIXELS / width, 2 * GUARD_BAND_PIXELS / height
    tris = []
    for f, face in enumerate(faces):
        poly = clip_triangle([clip[i] for i in face], gx, gy)
        for j in range(1, len(poly) - 1):
            verts = [poly[0], poly[j], poly[j + 1]]
            xs, ys, zs, iws, bs = [], [], [], [], []
            for c, b in verts:
                xs.append(int(np.rint((c[0] / c[3] + 1.0) * (0.5 * width) * 256.0)))
                ys.append(int(np.rint((c[1] / c[3] + 1.0) * (0.5 * height) * 256.0)))
                zs.append(0.5 * (c[2] / c[3]) + 0.5)
                iws.append(1.0 / c[3])
                bs.append(b)
            area = edge(xs[0], ys[0], xs[1], ys[1], xs[2], ys[2])
            order = [0, 1, 2] if area >= 0 else [0, 2, 1]
            tris.append(dict(face=f, area=abs(area), x=[xs[k] for k in order], y=[ys[k] for k in order],
                             z=[zs[k] for k in order], iw=[iws[k] for k in order],
                             B=np.array([bs[k] for k in order])))
    return tris


def is_inclusive(ax, ay, bx, by):
    """Left edge (dy < 0) or bottom edge (dy == 0, dx > 0) of a counter-clockwise triangle."""
    dx, dy = bx - ax, by - ay
    return dy < 0 or (dy == 0 and dx > 0)


def naive_rasterize(clip, faces, width, height, peel=None):
    """Returns depth (float32), face index (int32), clip-triangle list index (int32), triangles."""
    tris = setup_triangles(np.asarray(clip, dtype=np.float64), np.asarray(faces), width, height)
    depth = np.ones((height, width), dtype=np.float32)
    face = np.full((height, width), -1, dtype=np.int32)
    which = np.full((height, width), -1, dtype=np.int32)
    rows, cols = np.mgrid[0:height, 0:width]
    px = cols.astype(np.int64) * 256 + 128
    py = (height - 1 - rows).astype(np.int64) * 256 + 128
    for t, tri in enumerate(tris):
        if tri["area"] == 0:
            continue
        x, y, z = tri["x"], tri["y"], tri["z"]
        covered = np.ones((height, width), dtype=bool)
        e = []
        for i in range(3):
            a, b = (i + 1) % 3, (i + 2) % 3
            ei = edge(x[a], y[a], x[b], y[b], px, py)
            covered &= (ei > 0) | ((ei == 0) & is_inclusive(x[a], y[a], x[b], y[b]))
            e.append(ei)
        zz = (e[0].astype(np.float64) * z[0] + e[1].astype(np.float64) * z[1] + e[2].astype(np.float64) * z[2]) \
            * (1.0 / float(tri["area"]))
        zz = np.clip(zz, 0.0, 1.0).astype(np.float32)
        win = covered & (zz < depth)
        if peel is not None:
            win &= zz > peel
        depth[win] = zz[win]
        face[win] = tri["face"]
        which[win] = t
    return depth, face, which, tris


def naive_interpolate(which, tris, attributes, faces, dtype, normalize=False):
    """Perspective-correct interpolation, pixel by pixel, in ``dtype`` (same formula as spec section 2)."""
    h, w = which.shape
    attr = np.asarray(attributes, dtype=dtype)
    out = np.zeros((h, w, attr.shape[1]), dtype=dtype)
    for r in range(h):
        for c in range(w):
            t = which[r, c]
            if t < 0:
                continue
            tri = tris[t]
            x, y = tri["x"], tri["y"]
            px, py = c * 256 + 128, (h - 1 - r) * 256 + 128
            e = [edge(x[(i + 1) % 3], y[(i + 1) % 3], x[(i + 2) % 3], y[(i + 2) % 3], px, py) for i in range(3)]
            a = [dtype(e[i]) * dtype(tri["iw"][i]) for i in range(3)]
            s = a[0] + a[1] + a[2]
            lam = [a[i] / s for i in range(3)]
            B = tri["B"].astype(dtype)
            bary = [lam[0] * B[0, j] + lam[1] * B[1, j] + lam[2] * B[2, j] for j in range(3)]
            v = faces[tri["face"]]
            val = bary[0] * attr[v[0]] + bary[1] * attr[v[1]] + bary[2] * attr[v[2]]
            if normalize:
                length = np.sqrt(_sumsq(val))
                val = val / length if length > 0 else np.zeros_like(val)
            out[r, c] = val
    return out


def _sumsq(v):
    s = v[0] * v[0]
    for k in range(1, len(v)):
        s = s + v[k] * v[k]
    return s


# ------------------------------------------------------------------------------------ search
def naive_normalize(x, y, z, dt):
    length = np.sqrt((x * x + y * y) + z * z)
    inv = np.where(length > 0, dt(1.0) / np.where(length > 0, length, dt(1.0)), dt(0.0)).astype(dt)
    return (x * inv).astype(dt), (y * inv).astype(dt), (z * inv).astype(dt)


def naive_scores(P, N, eye, v, dt, inverse=False):
    """spec section 4.1 score (or the inverse score of 4.6) for arrays of pixels P, N (..., 3), in dt."""
    P = P.astype(dt)
    N = N.astype(dt)
    eye = np.asarray(eye).astype(dt)
    v = np.asarray(v).astype(dt)
    px, py, pz = P[..., 0], P[..., 1], P[..., 2]
    nx, ny, nz = N[..., 0], N[..., 1], N[..., 2]
    vx, vy, vz = (np.full(px.shape, v[i], dtype=dt) for i in range(3))
    if inverse:
        k = dt(2.0) * (((vx - px) * nx + (vy - py) * ny) + (vz - pz) * nz)
        vx, vy, vz = vx - k * nx, vy - k * ny, vz - k * nz
    ax, ay, az = naive_normalize(eye[0] - px, eye[1] - py, eye[2] - pz, dt)
    bx, by, bz = naive_normalize(vx - px, vy - py, vz - pz, dt)
    hx, hy, hz = naive_normalize(ax + bx, ay + by, az + bz, dt)
    return ((nx * hx + ny * hy) + nz * hz).astype(dt)


CROSS = [(0, 0), (0, -1), (-1, 0), (0, 1), (1, 0)]
BOX = CROSS + [(-1, -1), (-1, 1), (1, 1), (1, -1)]


def naive_walk(P, N, mask, eye, v, r, c, offsets, cap, dt, inverse):
    """Plain hill climb (spec section 4.2 / 4.4): returns r, c, score, margin, iterations, capped, border."""
    h, w = mask.shape

    def s(rr, cc):
        return naive_scores(P[rr, cc], N[rr, cc], eye, v, dt, inverse)[()]

    it = 0
    while True:
        it += 1
        best, best_rc, second, border = s(r, c), (r, c), None, False
        for dr, dc in offsets[1:]:
            rr, cc = r + dr, c + dc
            if not (0 <= rr < h and 0 <= cc < w) or not mask[rr, cc]:
                border = True
                continue
            sc = s(rr, cc)
            if sc > best:
                second, best, best_rc = best, sc, (rr, cc)
            elif second is None or sc > second:
                second = sc
        if best_rc == (r, c):
            margin = best - second if second is not None else dt(2.0)
            return r, c, best, margin, it, False, border
        if it >= cap:
            cur = s(r, c)
            return r, c, cur, best - cur, it, True, border
        r, c = best_rc


def naive_search(P, N, mask, eye, v, start, neighbourhood, cap, dt, inverse_search):
    offsets = CROSS if neighbourhood == "cross" else BOX
    r, c, best, margin, it, capped, border = naive_walk(P, N, mask, eye, v, start[0], start[1], offsets, cap, dt,
                                                        False)
    flags = 4 if capped else 0
    p, n = P[r, c].astype(dt), N[r, c].astype(dt)
    vv = np.asarray(v).astype(dt)
    d = ((vv[0] - p[0]) * n[0] + (vv[1] - p[1]) * n[1]) + (vv[2] - p[2]) * n[2]
    if d < 0:
        flags |= 1
        if inverse_search:
            r, c, best, margin, it2, capped, border = naive_walk(P, N, mask, eye, v, r, c, offsets, cap, dt, True)
            it += it2
            flags |= 4 if capped else 0
    flags |= 2 if border else 0
    return (r, c), best, margin, it, flags


def naive_refine(P, N, mask, vertices, eye, pixel, flags, hidden_bit, culled_bit, max_offset=1.0):
    """One Gauss-Newton step on N(x) - h(x) = 0 per vertex, float64, written out: derivatives of
    the residual, P and N by central differences (one-sided beside an uncovered texel, none
    when both neighbours are uncovered), the 2x2 normal equations solved by Cramer's rule
    (one axis alone when the other has no derivative, nothing when nearly singular), the step
    clamped to [-max_offset, max_offset], P and N (renormalised) by the first-order model.
    Returns (P, N, offset)."""
    P = np.asarray(P, np.float64)
    N = np.asarray(N, np.float64)
    h, w = mask.shape
    n = len(vertices)
    out_p, out_n, out_o = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 2))

    def covered(r, c):
        return 0 <= r < h and 0 <= c < w and bool(mask[r, c])

    def residual(r, c, v):
        u = (eye - P[r, c]) / np.linalg.norm(eye - P[r, c])
        b = (v - P[r, c]) / np.linalg.norm(v - P[r, c])
        hh = (u + b) / np.linalg.norm(u + b)
        return N[r, c] - hh

    def derivative(field, r, c, dr, dc):
        plus, minus = covered(r + dr, c + dc), covered(r - dr, c - dc)
        if plus and minus:
            return (field(r + dr, c + dc) - field(r - dr, c - dc)) / 2.0
        if plus:
            return field(r + dr, c + dc) - field(r, c)
        if minus:
            return field(r, c) - field(r - dr, c - dc)
        return np.zeros(3)

    for i in range(n):
        r, c = int(pixel[i, 0]), int(pixel[i, 1])
        if flags[i] & culled_bit:
            continue
        if flags[i] & hidden_bit:
            out_p[i], out_n[i] = P[r, c], N[r, c]
            continue
        v = np.asarray(vertices[i], np.float64)
        d0 = residual(r, c, v)
        jr = derivative(lambda a, b: residual(a, b, v), r, c, 1, 0)
        jc = derivative(lambda a, b: residual(a, b, v), r, c, 0, 1)
        a00, a01, a11 = jr @ jr, jr @ jc, jc @ jc
        b0, b1 = -(jr @ d0), -(jc @ d0)
        det = a00 * a11 - a01 * a01
        t = np.zeros(2)
        if det > 1e-6 * a00 * a11:
            t = np.array([a11 * b0 - a01 * b1, a00 * b1 - a01 * b0]) / det
        elif a11 == 0 and a00 > 0:
            t[0] = b0 / a00
        elif a00 == 0 and a11 > 0:
            t[1] = b1 / a11
        t = np.clip(t, -max_offset, max_offset)
        out_o[i] = t
        out_p[i] = P[r, c] + t[0] * derivative(lambda a, b: P[a, b], r, c, 1, 0) \
            + t[1] * derivative(lambda a, b: P[a, b], r, c, 0, 1)
        nn = N[r, c] + t[0] * derivative(lambda a, b: N[a, b], r, c, 1, 0) \
            + t[1] * derivative(lambda a, b: N[a, b], r, c, 0, 1)
        out_n[i] = nn / np.linalg.norm(nn)
    return out_p, out_n, out_o


def naive_edge_errors(gbuffer, eye, a_world, b_world, pa, pb, oa=None, ob=None):
    """The thesis's edge error, NumPy, float64 (refsoft.search.tessellate.edge_errors): at the texel
    halfway between the reflection pixels (rounded down), or with offsets at the midpoint of the
    refined points by the first-order model (refsoft.search.refine.surface_at) at the nearest
    covered texel, else the halfway texel; 1 where a pixel is missing or nothing is covered."""
    from refsoft.search.refine import surface_at

    e = len(a_world)
    out = np.ones(e)
    pa, pb = np.asarray(pa, np.int64), np.asarray(pb, np.int64)
    h, w = gbuffer.mask.shape
    for i in range(e):
        if (pa[i] < 0).any() or (pb[i] < 0).any():
            continue
        half = (pa[i] + pb[i]) // 2
        if oa is None:
            if not gbuffer.mask[half[0], half[1]]:
                continue
            p = gbuffer.position[half[0], half[1]].astype(np.float64) + gbuffer.origin
            n = gbuffer.normal[half[0], half[1]].astype(np.float64)
        else:
            mid = 0.5 * ((pa[i] + np.asarray(oa[i], np.float64)) + (pb[i] + np.asarray(ob[i], np.float64)))
            base = np.floor(mid + 0.5).astype(np.int64)
            if not (0 <= base[0] < h and 0 <= base[1] < w and gbuffer.mask[base[0], base[1]]):
                base = half
                if not gbuffer.mask[base[0], base[1]]:
                    continue
            ps, ns = surface_at(gbuffer, base[None], (mid - base)[None])
            p = ps[0].astype(np.float64) + gbuffer.origin
            n = ns[0].astype(np.float64)
        m = 0.5 * (np.asarray(a_world[i], np.float64) + np.asarray(b_world[i], np.float64))
        v = (eye - p) / np.linalg.norm(eye - p)
        u = (m - p) / np.linalg.norm(m - p)
        b = (v + u) / np.linalg.norm(v + u)
        out[i] = 1.0 - (n @ b + 1.0) / 2.0
    return out


def naive_start_pixel(mask):
    """spec section 4.3's start, over every pixel: the bounding box's centre, else the covered pixel
    nearest to it (Euclidean, ties to the smaller row, then col); None when nothing is covered."""
    pts = [(r, c) for r in range(mask.shape[0]) for c in range(mask.shape[1]) if mask[r, c]]
    if not pts:
        return None
    r = (min(p[0] for p in pts) + max(p[0] for p in pts)) // 2
    c = (min(p[1] for p in pts) + max(p[1] for p in pts)) // 2
    if mask[r, c]:
        return r, c
    return min(pts, key=lambda p: ((p[0] - r) ** 2 + (p[1] - c) ** 2, p[0], p[1]))


def naive_virtual_vertices(gbuffer, result, vertices, surface=None, rule="mirror", eye=None):
    """spec section 4.6's virtual vertices in NumPy, relative to the G-buffer's origin, in its
    precision (refsoft.search.virtual_vertices with relative=True): V - 2 (d.N) N for visible
    vertices (``rule="unfold"``: P + normalize(P - O) |V - P|), by mode for hidden ones (plane:
    P + N (2 d.N) - d; search: V; discard: the mirror formula), V for CULLED ones; ``surface``
    (P, N) per vertex in place of the texel's."""
    HIDDEN, CULLED = 1, 16
    dt = gbuffer.position.dtype.type
    v = (np.asarray(vertices, np.float64) - gbuffer.origin).astype(dt)
    ok = (result.flags & CULLED) == 0
    r = np.where(ok, result.pixel[:, 0], 0)
    c = np.where(ok, result.pixel[:, 1], 0)
    if surface is None:
        p, nrm = gbuffer.position[r, c], gbuffer.normal[r, c]
    else:
        p, nrm = (np.asarray(a, dtype=dt).reshape(len(v), 3) for a in surface)
    d = v - p
    dn = (d[:, 0] * nrm[:, 0] + d[:, 1] * nrm[:, 1]) + d[:, 2] * nrm[:, 2]
    two = dt(2.0)
    mirror = v - (two * dn)[:, None] * nrm
    hidden = ok & ((result.flags & HIDDEN) != 0)
    if rule == "unfold":
        e = (np.asarray(eye, np.float64) - gbuffer.origin).astype(dt)
        length = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])
        ux, uy, uz = naive_normalize(p[:, 0] - e[0], p[:, 1] - e[1], p[:, 2] - e[2], dt)
        unfolded = np.stack([p[:, 0] + ux * length, p[:, 1] + uy * length, p[:, 2] + uz * length], axis=1)
        mirror = np.where(hidden[:, None], mirror, unfolded)
    out = np.where(ok[:, None], mirror, v)
    if result.inverse == "plane":
        out = np.where(hidden[:, None], p + nrm * (two * dn)[:, None] - d, out)
    elif result.inverse == "search":
        out = np.where(hidden[:, None], v, out)
    return out


def naive_subdivide(vertices, faces, normals, max_edge, scale=(1.0, 1.0, 1.0)):
    """Loader subdivision (``refsoft.scene.subdivide``), one edge and one face at a time.

    Returns vertices (V', 3), faces (F', 3) and normals (V', 3) as NumPy arrays.
    """
    import math

    P = [tuple(float(c) for c in v) for v in vertices]
    N = [tuple(float(c) for c in v) for v in normals]
    F = [tuple(int(i) for i in f) for f in faces]
    s = [float(c) for c in scale]
    limit = float(max_edge) * float(max_edge)

    def key(i, j):
        return (min(i, j), max(i, j))

    def len2(i, j):
        lo, hi = key(i, j)
        d = [(P[hi][k] - P[lo][k]) * s[k] for k in range(3)]
        return d[0] * d[0] + d[1] * d[1] + d[2] * d[2]

    while True:
        long = set()
        for f in F:
            for k in range(3):
                if len2(f[k], f[(k + 1) % 3]) > limit:
                    long.add(key(f[k], f[(k + 1) % 3]))
        if not long:
            break
        mid = {}
        for a, b in sorted(long):
            mid[(a, b)] = len(P)
            P.append(tuple((P[a][k] + P[b][k]) * 0.5 for k in range(3)))
            m = [(N[a][k] + N[b][k]) * 0.5 for k in range(3)]
            if m == [0.0, 0.0, 0.0]:
                m = list(N[a])
            length = math.sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2])
            N.append(tuple(c / length for c in m) if length > 0 else (0.0, 0.0, 0.0))
        new = []
        for f in F:
            ms = [mid.get(key(f[k], f[(k + 1) % 3])) for k in range(3)]
            split = [k for k in range(3) if ms[k] is not None]
            if not split:
                new.append(f)
            elif len(split) == 1:
                k = split[0]
                a, b, c, m = f[k], f[(k + 1) % 3], f[(k + 2) % 3], ms[k]
                new += [(a, m, c), (m, b, c)]
            elif len(split) == 2:
                k = [k for k in range(3) if ms[k] is None][0]
                q, r, p = f[k], f[(k + 1) % 3], f[(k + 2) % 3]
                m_rp, m_pq = ms[(k + 1) % 3], ms[(k + 2) % 3]
                da, db = len2(q, m_rp), len2(r, m_pq)
                new.append((m_rp, p, m_pq))
                if da < db or (da == db and q < r):
                    new += [(q, r, m_rp), (q, m_rp, m_pq)]
                else:
                    new += [(q, r, m_pq), (r, m_rp, m_pq)]
            else:
                (v0, v1, v2), (m0, m1, m2) = f, ms
                new += [(v0, m0, m2), (v1, m1, m0), (v2, m2, m1), (m0, m1, m2)]
        F = new
    return np.array(P, dtype=np.float64), np.array(F, dtype=np.int64), np.array(N, dtype=np.float64)


# ------------------------------------------------------------------------------------ shading
def naive_shade(normals, object_id, table, light, ambient, diffuse):
    """spec section 5's shading one pixel at a time, in float32 scalars: ``table[id] * (ambient +
    diffuse * |n . light|)`` with the dot product summed x, then y, then z; ``table[0]`` (the
    background colour) where ``id == 0``. Returns (H, W, 3) float32."""
    f32 = np.float32
    h, w = object_id.shape
    lx, ly, lz = (f32(x) for x in light)
    out = np.empty((h, w, 3), dtype=np.float32)
    for r in range(h):
        for c in range(w):
            k = int(object_id[r, c])
            if k == 0:
                out[r, c] = [f32(x) for x in table[0]]
                continue
            nx, ny, nz = (f32(x) for x in normals[r, c])
            d = nx * lx + ny * ly
            d = d + nz * lz
            f = f32(ambient) + f32(diffuse) * abs(d)
            for ch in range(3):
                out[r, c, ch] = f32(table[k, ch]) * f
    return out


def naive_object_ids(triangle, face_offset):
    """Per pixel the object of the visible triangle ``t`` (1-based: object ``k`` owns triangles
    ``face_offset[k - 1]`` to ``face_offset[k] - 1``) and ``t``'s index within it; (0, -1) where
    ``t < 0``. Found by walking the offsets, not by a table."""
    h, w = triangle.shape
    ids = np.zeros((h, w), dtype=np.int32)
    local = np.full((h, w), -1, dtype=np.int32)
    for r in range(h):
        for c in range(w):
            t = int(triangle[r, c])
            if t < 0:
                continue
            k = 1
            while face_offset[k] <= t:
                k += 1
            ids[r, c] = k
            local[r, c] = t - face_offset[k - 1]
    return ids, local


def naive_to_uint8(color):
    """``round(clip(c, 0, 1) * 255)`` element by element in Python floats (``round`` rounds
    half to even); NaN gives 0."""
    flat = [float(x) for x in np.asarray(color).reshape(-1)]
    out = [0 if x != x else int(round(min(max(x, 0.0), 1.0) * 255.0)) for x in flat]
    return np.array(out, dtype=np.uint8).reshape(np.shape(color))


# ------------------------------------------------------------------------------------ skips
def naive_outside_box(clip3, bounds):
    """One triangle's clip vertices (3, 4) all strictly beyond one side of the NDC ``bounds``
    ``(x_lo, x_hi, y_lo, y_hi)`` (``x > x_hi w`` and the like) or all behind the near plane
    (``z < -w``)."""
    x_lo, x_hi, y_lo, y_hi = bounds
    sides = (lambda x, y, z, w: x > x_hi * w, lambda x, y, z, w: x < x_lo * w,
             lambda x, y, z, w: y > y_hi * w, lambda x, y, z, w: y < y_lo * w,
             lambda x, y, z, w: z < -w)
    return any(all(side(*(float(a) for a in v)) for v in clip3) for side in sides)


def naive_triangles_outside_box(clip, faces, bounds):
    """:func:`naive_outside_box` of every triangle, bool (F,)."""
    return np.array([naive_outside_box([clip[int(i)] for i in f], bounds) for f in faces], dtype=bool)


# ------------------------------------------------------------------------------------ tessellation
def naive_split(faces, midpoints, only=None):
    """Red-green refinement one triangle at a time. ``midpoints`` maps an undirected edge
    ``(min, max)`` to its new vertex. A triangle (a, b, c) with its edges ab, bc, ca split gives
    (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca); with one edge v0-v1 split (v2 opposite)
    (v0, m, v2), (m, v1, v2); with all but edge v0-v1 split (v0, v1, m12), (v0, m12, m20),
    (m20, m12, v2). ``only`` (bool per triangle): the others are left whole. Returns
    ``(faces (T', 3) int64, parent (T',) int64)``, children in their parents' order."""
    out, parent = [], []
    for t, face in enumerate(faces):
        v = [int(x) for x in face]
        m = [midpoints.get((min(v[i], v[(i + 1) % 3]), max(v[i], v[(i + 1) % 3])), -1) for i in range(3)]
        if only is not None and not only[t]:
            m = [-1, -1, -1]
        n = sum(x >= 0 for x in m)
        if n == 0:
            kids = [v]
        elif n == 3:
            kids = [[v[0], m[0], m[2]], [m[0], v[1], m[1]], [m[2], m[1], v[2]], [m[0], m[1], m[2]]]
        else:
            # turn the triangle so that its edge 0 (v0-v1) is the one split (n == 1) or unsplit (2)
            k = [x >= 0 for x in m].index(n == 1)
            v0, v1, v2 = v[k], v[(k + 1) % 3], v[(k + 2) % 3]
            m01, m12, m20 = m[k], m[(k + 1) % 3], m[(k + 2) % 3]
            if n == 1:
                kids = [[v0, m01, v2], [m01, v1, v2]]
            else:
                kids = [[v0, v1, m12], [v0, m12, m20], [m20, m12, v2]]
        out += kids
        parent += [t] * len(kids)
    return np.array(out, dtype=np.int64).reshape(-1, 3), np.array(parent, dtype=np.int64)


def _naive_arc(eye_dir, point_dir):
    """Orthonormal (a, b) spanning the arc from eye_dir towards point_dir, and its angle."""
    a = eye_dir
    b = point_dir - (point_dir @ a) * a
    nb = np.linalg.norm(b)
    phi = float(np.arccos(np.clip(point_dir @ a, -1.0, 1.0)))
    if nb < 1e-15:
        b = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(b) < 1e-6:
            b = np.cross(a, [0.0, 1.0, 0.0])
        b /= np.linalg.norm(b)
    else:
        b = b / nb
    return a, b, phi


def _naive_arc_function(t, a, b, c, rho, o, v):
    """``(u + v) . T`` at arc angle ``t`` (broadcasting over leading axes; last axis xyz)."""
    n = np.cos(t) * a + np.sin(t) * b
    r = c + rho * n
    u = o - r
    w = v - r
    s = u / np.linalg.norm(u, axis=-1, keepdims=True) + w / np.linalg.norm(w, axis=-1, keepdims=True)
    return np.sum(s * (-np.sin(t) * a + np.cos(t) * b), axis=-1)


def naive_sphere_reflection_points(centre, radius, eye, points, samples=64):
    """refsoft.truth.analytic.sphere_reflection_points with SciPy: the arc from the eye's
    direction to the point's sampled at ``samples`` + 1 angles, each sign change solved by
    ``scipy.optimize.brentq`` (xtol 1e-15, rtol 4 eps, 200 iterations), the first root with the
    eye and the point outside the tangent plane kept; NaN rows where there is none."""
    from scipy.optimize import brentq

    c = np.asarray(centre, dtype=np.float64).reshape(3)
    rho = float(radius)
    o = np.asarray(eye, dtype=np.float64).reshape(3)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.full((len(pts), 3), np.nan)
    eye_dir = (o - c) / np.linalg.norm(o - c)
    outside = np.flatnonzero(np.linalg.norm(pts - c, axis=1) > rho)
    if len(outside) == 0:
        return out
    arcs = [_naive_arc(eye_dir, (pts[i] - c) / np.linalg.norm(pts[i] - c)) for i in outside]
    A = np.array([a for a, _, _ in arcs])
    B = np.array([b for _, b, _ in arcs])
    phi = np.array([p for _, _, p in arcs])
    # bracket the roots of every point at once: f on samples + 1 points of each arc
    ts = phi[:, None] * np.linspace(0.0, 1.0, samples + 1)[None, :]
    fs = _naive_arc_function(ts[..., None], A[:, None], B[:, None], c, rho, o, pts[outside][:, None])
    for j, i in enumerate(outside):
        a, b, v = A[j], B[j], pts[i]

        def f(t):
            return float(_naive_arc_function(t, a, b, c, rho, o, v))

        candidates = [ts[j, k] if fs[j, k] == 0.0 else (ts[j, k], ts[j, k + 1])
                      for k in range(samples) if fs[j, k] == 0.0 or fs[j, k] * fs[j, k + 1] < 0.0]
        if fs[j, -1] == 0.0 and phi[j] > 0:
            candidates.append(ts[j, -1])
        for cand in candidates:
            t = cand if np.isscalar(cand) else brentq(f, cand[0], cand[1], xtol=1e-15,
                                                       rtol=4 * np.finfo(float).eps, maxiter=200)
            n = np.cos(t) * a + np.sin(t) * b
            r = c + rho * n
            if (o - r) @ n > 0.0 and (v - r) @ n > 0.0:
                out[i] = r
                break
    return out


# ------------------------------------------------------------------ two nearest fragments
def naive_depth_layers(clip, faces, width, height):
    """The two nearest fragments of every pixel, by listing every fragment that covers it.

    Returns ``(depth, face, which, depth2, face2, which2, tris)``: the winner (the smallest
    depth, the first drawn among equal ones, as :func:`naive_rasterize`) and the second (the
    smallest depth among the other fragments, the first drawn among equal ones; depth +inf and
    -1 where there is none). ``which`` and ``which2`` index ``tris``."""
    tris = setup_triangles(np.asarray(clip, dtype=np.float64), np.asarray(faces), width, height)
    rows, cols = np.mgrid[0:height, 0:width]
    px = cols.astype(np.int64) * 256 + 128
    py = (height - 1 - rows).astype(np.int64) * 256 + 128
    frags = [[[] for _ in range(width)] for _ in range(height)]  # (depth, draw order) per pixel
    for t, tri in enumerate(tris):
        if tri["area"] == 0:
            continue
        x, y, z = tri["x"], tri["y"], tri["z"]
        covered = np.ones((height, width), dtype=bool)
        e = []
        for i in range(3):
            a, b = (i + 1) % 3, (i + 2) % 3
            ei = edge(x[a], y[a], x[b], y[b], px, py)
            covered &= (ei > 0) | ((ei == 0) & is_inclusive(x[a], y[a], x[b], y[b]))
            e.append(ei)
        zz = (e[0].astype(np.float64) * z[0] + e[1].astype(np.float64) * z[1] + e[2].astype(np.float64) * z[2]) \
            * (1.0 / float(tri["area"]))
        zz = np.clip(zz, 0.0, 1.0).astype(np.float32)
        for r, c in zip(*np.nonzero(covered)):
            frags[r][c].append((zz[r, c], t))
    depth = np.ones((height, width), dtype=np.float32)
    depth2 = np.full((height, width), np.inf, dtype=np.float32)
    which = np.full((height, width), -1, dtype=np.int32)
    which2 = np.full((height, width), -1, dtype=np.int32)
    for r in range(height):
        for c in range(width):
            ranked = sorted(frags[r][c])  # by depth, then draw order
            if ranked and ranked[0][0] < 1.0:  # a fragment at depth 1 does not pass LESS against the clear value
                depth[r, c], which[r, c] = ranked[0]
                if len(ranked) > 1:
                    depth2[r, c], which2[r, c] = ranked[1]
    face = np.where(which >= 0, [[tris[t]["face"] if t >= 0 else -1 for t in row] for row in which], -1)
    face2 = np.where(which2 >= 0, [[tris[t]["face"] if t >= 0 else -1 for t in row] for row in which2], -1)
    return depth, face.astype(np.int32), which, depth2, face2.astype(np.int32), which2, tris


# ------------------------------------------------------- a GPU's own attribute interpolation
def naive_gl_interpolate(clip, faces, triangle, attributes, width, height, normalize=False):
    """Attributes of the triangles ``triangle`` (H, W; -1 none) as a GPU interpolates them,
    everything in float32: window coordinates of the unsnapped vertices, edge functions at the
    pixel centre, weights ``e_i / w_i`` normalised, and (``normalize``) ``v / sqrt(v . v)``.
    Triangles crossing the near plane are not handled (the G-buffers this is used on have none)."""
    f32 = np.float32
    clip = np.asarray(clip, dtype=f32)
    rows, cols = np.nonzero(triangle >= 0)
    v = np.asarray(faces)[triangle[rows, cols]]
    x = (clip[v, 0] / clip[v, 3] + f32(1)) * f32(0.5 * width)
    y = (clip[v, 1] / clip[v, 3] + f32(1)) * f32(0.5 * height)
    iw = f32(1) / clip[v, 3]
    px = (cols + 0.5).astype(f32)[:, None]
    py = (height - rows - 0.5).astype(f32)[:, None]
    j, k = [1, 2, 0], [2, 0, 1]
    e = (x[:, k] - x[:, j]) * (py - y[:, j]) - (y[:, k] - y[:, j]) * (px - x[:, j])
    a = e * iw
    lam = a / (a[:, 0] + a[:, 1] + a[:, 2])[:, None]
    attr = np.asarray(attributes, dtype=f32)[v]  # (n, 3, C)
    val = lam[:, 0, None] * attr[:, 0] + lam[:, 1, None] * attr[:, 1] + lam[:, 2, None] * attr[:, 2]
    if normalize:
        length = np.sqrt(_sumsq(val.T))
        val = np.where(length[:, None] > 0, val / np.where(length > 0, length, f32(1))[:, None], f32(0))
    out = np.zeros(triangle.shape + (attr.shape[2],), dtype=f32)
    out[rows, cols] = val
    return out
