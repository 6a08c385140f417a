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


def _dot3(x, y):
    """``(x0 y0 + x1 y1) + x2 y2`` in that order: ``x @ y`` goes through the BLAS NumPy was built
    with, whose ``ddot`` may fuse or reorder the products (its bits are not NumPy's promise)."""
    return (float(x[0]) * float(y[0]) + float(x[1]) * float(y[1])) + float(x[2]) * float(y[2])


def _norm3(x):
    """``sqrt(_dot3(x, x))`` (a 1-D ``np.linalg.norm`` is BLAS's too)."""
    return float(np.sqrt(_dot3(x, x)))


def _naive_arc(eye_dir, point_dir):
    """Orthonormal (a, b) spanning the arc from eye_dir towards point_dir, and its angle."""
    a = eye_dir
    b = point_dir - _dot3(point_dir, a) * a
    nb = _norm3(b)
    phi = float(np.arccos(np.clip(_dot3(point_dir, a), -1.0, 1.0)))
    if nb < 1e-15:
        b = np.cross(a, [1.0, 0.0, 0.0])
        if _norm3(b) < 1e-6:
            b = np.cross(a, [0.0, 1.0, 0.0])
        b /= _norm3(b)
    else:
        b = b / nb
    return a, b, phi


def _naive_arc_function(t, a, b, c, rho, o, v):
    """``(u + v) . T`` at arc angle ``t`` (broadcasting over leading axes; last axis xyz)."""
    n = np.cos(t) * a + np.sin(t) * b
    r = c + rho * n
    u = o - r
    w = v - r
    s = u / np.sqrt(_dot_last(u, u))[..., None] + w / np.sqrt(_dot_last(w, w))[..., None]
    return _dot_last(s, -np.sin(t) * a + np.cos(t) * b)


def _dot_last(x, y):
    """:func:`_dot3` over the last axis of arrays (elementwise, so in that order too)."""
    return (x[..., 0] * y[..., 0] + x[..., 1] * y[..., 1]) + x[..., 2] * y[..., 2]


def naive_brent(f, lo, hi, f_lo, f_hi, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200):
    """A root of ``f`` in ``[lo, hi]`` (``f_lo = f(lo)`` and ``f_hi = f(hi)`` of opposite signs)
    by Brent's method (R. P. Brent, "Algorithms for Minimization without Derivatives", 1973,
    chapter 4), written out plainly in Python floats.

    ``b`` is the best estimate, ``a`` the previous one and ``c`` the other end of the bracket
    ``[b, c]``. Each step tries inverse quadratic interpolation through ``a, b, c`` (the secant
    through ``a, b`` when ``a == c``) and takes it when it lands well inside the bracket and the
    step before last was large enough; otherwise it bisects. A step smaller than the tolerance
    ``(xtol + rtol |b|) / 2`` is made the tolerance itself. The stopping rule and the step rule
    are those ``scipy.optimize.brentq`` documents, so the result meets its guarantee
    ``|x - root| <= xtol + rtol |root|``.
    """
    a, b = float(lo), float(hi)
    fa, fb = float(f_lo), float(f_hi)
    c, fc = 0.0, 0.0
    d = e = 0.0  # the last step and the one before it
    for _ in range(maxiter):
        if fa != 0.0 and fb != 0.0 and (fa < 0.0) != (fb < 0.0):
            c, fc = a, fa  # the root lies between b and c
            d = e = b - a
        if abs(fc) < abs(fb):  # make b the end with the smaller residual
            a, b, c = b, c, b
            fa, fb, fc = fb, fc, fb
        tol = (xtol + rtol * abs(b)) / 2.0
        m = (c - b) / 2.0
        if fb == 0.0 or abs(m) < tol:
            return b
        interpolate = None
        if abs(e) > tol and abs(fb) < abs(fa):
            if a == c:
                p = -fb * (b - a) / (fb - fa)
            else:
                slope_a = (fa - fb) / (a - b)
                slope_c = (fc - fb) / (c - b)
                p = -fb * (fc * slope_c - fa * slope_a) / (slope_c * slope_a * (fc - fa))
            if 2.0 * abs(p) < min(abs(e), 3.0 * abs(m) - tol):
                interpolate = p
        if interpolate is None:
            e = d = m
        else:
            e, d = d, interpolate
        a, fa = b, fb
        if abs(d) > tol:
            b += d
        elif m > 0.0:
            b += tol
        else:
            b -= tol
        fb = f(b)
    return b


def scipy_brent(f, lo, hi, f_lo, f_hi, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200):
    """:func:`naive_brent`'s interface on ``scipy.optimize.brentq`` (same xtol, rtol, maxiter)."""
    from scipy.optimize import brentq

    return brentq(f, lo, hi, xtol=xtol, rtol=rtol, maxiter=maxiter)


def naive_sphere_reflection_points(centre, radius, eye, points, samples=64, solver=naive_brent, angles=False):
    """refsoft.truth.analytic.sphere_reflection_points in plain NumPy: the arc from the eye's
    direction to the point's sampled at ``samples`` + 1 angles, each sign change solved by
    ``solver`` (:func:`naive_brent`, or :func:`scipy_brent`), the first root with the eye and the
    point outside the tangent plane kept; NaN rows where there is none. With ``angles``, also
    each point's root angle on its arc and the arc's angle (NaN where none)."""
    c = np.asarray(centre, dtype=np.float64).reshape(3)
    rho = float(radius)
    o = np.asarray(eye, dtype=np.float64).reshape(3)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.full((len(pts), 3), np.nan)
    root_angle = np.full(len(pts), np.nan)
    arc_angle = np.full(len(pts), np.nan)
    eye_dir = (o - c) / _norm3(o - c)
    dist = np.array([_norm3(p - c) for p in pts])
    outside = np.flatnonzero(dist > rho)
    if len(outside) == 0:
        return (out, root_angle, arc_angle) if angles else out
    arcs = [_naive_arc(eye_dir, (pts[i] - c) / dist[i]) for i in outside]
    A = np.array([a for a, _, _ in arcs])
    B = np.array([b for _, b, _ in arcs])
    phi = np.array([p for _, _, p in arcs])
    arc_angle[outside] = phi
    # bracket the roots of every point at once: f on samples + 1 points of each arc
    ts = phi[:, None] * np.linspace(0.0, 1.0, samples + 1)[None, :]
    fs = _naive_arc_function(ts[..., None], A[:, None], B[:, None], c, rho, o, pts[outside][:, None])
    for j, i in enumerate(outside):
        a, b, v = A[j], B[j], pts[i]

        def f(t):
            return float(_naive_arc_function(t, a, b, c, rho, o, v))

        candidates = [k for k in range(samples) if fs[j, k] == 0.0 or fs[j, k] * fs[j, k + 1] < 0.0]
        if fs[j, -1] == 0.0 and phi[j] > 0:
            candidates.append(samples)
        for k in candidates:
            t = ts[j, k] if fs[j, k] == 0.0 else solver(f, ts[j, k], ts[j, k + 1], fs[j, k], fs[j, k + 1])
            n = np.cos(t) * a + np.sin(t) * b
            r = c + rho * n
            if _dot3(o - r, n) > 0.0 and _dot3(v - r, n) > 0.0:
                out[i] = r
                root_angle[i] = t
                break
    return (out, root_angle, arc_angle) if angles else out


# ------------------------------------------------------------------------------------ face culling
def naive_signed_areas(clip, faces, width, height):
    """The doubled signed window-space area (snapped, y up) of every clip triangle, in the order of
    :func:`setup_triangles` (which keeps only the absolute value)."""
    gx, gy = 2 * GUARD_BAND_PIXELS / width, 2 * GUARD_BAND_PIXELS / height
    out = []
    for face in np.asarray(faces):
        poly = clip_triangle([np.asarray(clip, dtype=np.float64)[i] for i in face], gx, gy)
        for j in range(1, len(poly) - 1):
            xs = [int(np.rint((c[0] / c[3] + 1.0) * (0.5 * width) * 256.0)) for c, _ in (poly[0], poly[j], poly[j + 1])]
            ys = [int(np.rint((c[1] / c[3] + 1.0) * (0.5 * height) * 256.0)) for c, _ in (poly[0], poly[j], poly[j + 1])]
            out.append(edge(xs[0], ys[0], xs[1], ys[1], xs[2], ys[2]))
    return out


def naive_rasterize_culled(clip, faces, width, height, peel=None, cull=None):
    """:func:`naive_rasterize` with face culling: ``"cw"`` keeps the clip triangles whose snapped
    signed area is < 0, ``"ccw"`` those > 0, None all. Returns depth, face index, clip-triangle
    index (into the full list), triangles."""
    tris = setup_triangles(np.asarray(clip, dtype=np.float64), np.asarray(faces), width, height)
    signed = naive_signed_areas(clip, faces, width, height)
    depth = np.ones((height, width), dtype=np.float32)
    face = np.full((height, width), -1, dtype=np.int32)
    which = np.full((height, width), -1, dtype=np.int32)
    rows, cols = np.mgrid[0:height, 0:width]
    px = cols.astype(np.int64) * 256 + 128
    py = (height - 1 - rows).astype(np.int64) * 256 + 128
    for t, tri in enumerate(tris):
        if tri["area"] == 0 or (cull == "cw" and signed[t] >= 0) or (cull == "ccw" and signed[t] <= 0):
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


# ------------------------------------------------------------------------------------ layered depth textures
#: GL 4.6 table 8.19 (cube map face selection), written out: face -> (sc, tc) of a direction r.
GL_CUBE_TABLE = {
    0: lambda r: (-r[2], -r[1]), 1: lambda r: (r[2], -r[1]),
    2: lambda r: (r[0], r[2]), 3: lambda r: (r[0], -r[2]),
    4: lambda r: (r[0], -r[1]), 5: lambda r: (-r[0], -r[1]),
}


def naive_gl_cube_lookup(r):
    """The GL cube-map rule for direction ``r``: the major axis (ties: z over y over x), the face
    (positive when r_a >= 0), ``s = (sc / |ma| + 1) / 2``, ``t = (tc / |ma| + 1) / 2``."""
    a = 2 if abs(r[2]) >= max(abs(r[0]), abs(r[1])) else (1 if abs(r[1]) >= abs(r[0]) else 0)
    f = 2 * a + (0 if r[a] >= 0 else 1)
    sc, tc = GL_CUBE_TABLE[f](r)
    ma = abs(r[a])
    return f, (sc / ma + 1) / 2, (tc / ma + 1) / 2


def naive_ldt(vertices, faces, R, closed, edge_eps=0.01):
    """A layered depth texture by exact ray casts: for every texel of every face, the line through
    its centre along the face's axis is intersected (float64) with every triangle.

    Closed meshes (winding made outward by the signed volume): the crossings facing the face
    (``sigma n_a > 0``) in depth order are the layers, the others in order the back depths.
    Open meshes: the nearest crossing of either winding, one layer, back 1.

    Returns a dict: ``depth``, ``back`` (6, L, R, R) float64 (1 where none), ``triangle``
    (6, L, R, R) int (-1 none), ``count`` (6, R, R) int, ``ambiguous`` (6, R, R) bool (a texel
    centre within ``edge_eps`` texels of a triangle edge, or two crossings at one depth), ``centre``,
    ``half``, ``slope`` (6, L, R, R) / ``back_slope``: the crossing triangle's depth change per
    texel (|d delta / dx| + |d delta / dy|).
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre = (lo + hi) / 2
    half = max(hi - lo) / 2 * R / (R - 2)
    q = (v - centre) / half
    if closed:
        vol = np.sum([np.dot(q[a], np.cross(q[b], q[c])) for a, b, c in f])
        if vol < 0:
            f = f[:, [0, 2, 1]]
    grid = (np.arange(R) + 0.5) / R * 2 - 1  # texel centres in sc / tc
    out = {k: [] for k in ("depth", "back", "triangle", "count", "ambiguous", "slope", "back_slope")}
    for face in range(6):
        a, sigma = face // 2, (1.0 if face % 2 == 0 else -1.0)
        # sc, tc of every vertex, by the GL table; window x ~ sc, y ~ tc
        sc = np.array([GL_CUBE_TABLE[face](p)[0] for p in q])
        tc = np.array([GL_CUBE_TABLE[face](p)[1] for p in q])
        delta = 0.5 * (1 - sigma * q[:, a])
        rows, cols = np.mgrid[0:R, 0:R]
        px = grid[cols]
        py = grid[R - 1 - rows]
        hits = []  # (depth grid, mask, front?, triangle, slope)
        ambiguous = np.zeros((R, R), dtype=bool)
        for t, (i, j, k) in enumerate(f):
            x = sc[[i, j, k]]
            y = tc[[i, j, k]]
            area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0])
            if area == 0:
                continue
            e = [(x[(m + 2) % 3] - x[(m + 1) % 3]) * (py - y[(m + 1) % 3])
                 - (y[(m + 2) % 3] - y[(m + 1) % 3]) * (px - x[(m + 1) % 3]) for m in range(3)]
            lam = [em / area for em in e]
            inside = (lam[0] >= 0) & (lam[1] >= 0) & (lam[2] >= 0)
            # distance of the centre to each edge line, in texels (a sc unit is R / 2 texels)
            for m in range(3):
                ex, ey = x[(m + 2) % 3] - x[(m + 1) % 3], y[(m + 2) % 3] - y[(m + 1) % 3]
                dist = np.abs(e[m]) / np.hypot(ex, ey) * R / 2
                ambiguous |= (dist < edge_eps) & (lam[0] >= -0.5) & (lam[1] >= -0.5) & (lam[2] >= -0.5)
            if not inside.any():
                continue
            z = lam[0] * delta[i] + lam[1] * delta[j] + lam[2] * delta[k]
            # the depth plane's gradient per texel
            dzx = ((delta[j] - delta[i]) * (y[2] - y[0]) - (y[1] - y[0]) * (delta[k] - delta[i])) / area
            dzy = ((x[1] - x[0]) * (delta[k] - delta[i]) - (delta[j] - delta[i]) * (x[2] - x[0])) / area
            slope = (abs(dzx) + abs(dzy)) * 2 / R
            # facing the face's camera (at q_a = sigma, looking towards -sigma): sigma n_a > 0
            n = np.cross(q[j] - q[i], q[k] - q[i])
            hits.append((z, inside, sigma * n[a] > 0, t, slope))
        L = 0
        layer_lists = [[[] for _ in range(R)] for _ in range(R)]
        for z, inside, front, t, slope in hits:
            for r, c in zip(*np.nonzero(inside)):
                layer_lists[r][c].append((z[r, c], front, t, slope))
        per = {}
        for r in range(R):
            for c in range(R):
                cr = sorted(layer_lists[r][c])
                zs = [h[0] for h in cr]
                if any(abs(zs[m + 1] - zs[m]) < 1e-9 for m in range(len(zs) - 1)):
                    ambiguous[r, c] = True
                if closed:
                    fr = [h for h in cr if h[1]]
                    bk = [h for h in cr if not h[1]]
                else:
                    fr, bk = cr[:1], []
                per[r, c] = (fr, bk)
                L = max(L, len(fr))
        out["ambiguous"].append(ambiguous)
        out["count"].append(np.array([[len(per[r, c][0]) for c in range(R)] for r in range(R)]))
        out["_per"] = out.get("_per", []) + [per]
    L = max(1, max(int(c.max()) for c in out["count"]))
    depth = np.ones((6, L, R, R))
    back = np.ones((6, L, R, R))
    tri = np.full((6, L, R, R), -1)
    slope = np.zeros((6, L, R, R))
    back_slope = np.zeros((6, L, R, R))
    for face, per in enumerate(out.pop("_per")):
        for (r, c), (fr, bk) in per.items():
            for j, h in enumerate(fr):
                depth[face, j, r, c], tri[face, j, r, c], slope[face, j, r, c] = h[0], h[2], h[3]
            for j, h in enumerate(bk[:L]):
                back[face, j, r, c], back_slope[face, j, r, c] = h[0], h[3]
    return dict(depth=depth, back=back, triangle=tri, count=np.array(out["count"]),
                ambiguous=np.array(out["ambiguous"]), centre=centre, half=half, slope=slope, back_slope=back_slope)


def naive_cone_cases(p1, p2, p3, eye, centre, rho):
    """The cone test of one triangle and one sphere written out (docs/ldt.md): returns the four
    cases (corner inside, edge meets the cone, axis hits the triangle, trivial pass)."""
    p1, p2, p3, C, O = (np.asarray(x, dtype=np.float64) for x in (p1, p2, p3, eye, centre))
    n = np.cross(p1 - p2, p3 - p2)
    if np.linalg.norm(n) == 0:
        return False, False, False, True
    n = n / np.linalg.norm(n)
    e = -np.dot(n, p1)
    Ov = O - 2 * (np.dot(n, O) + e) * n
    dist = np.linalg.norm(Ov - C)
    if dist <= rho:
        return False, False, False, True
    g = (Ov - C) / dist
    cos2 = 1 - rho ** 2 / dist ** 2

    def inside(x):
        v = x - C
        return np.dot(g, v) > 0 and np.dot(g, v) ** 2 >= cos2 * np.dot(v, v)

    corner = any(inside(p) for p in (p1, p2, p3))
    edge = False
    for a, b in ((p1, p2), (p2, p3), (p3, p1)):
        v0, d = a - C, b - a
        A = np.dot(g, d) ** 2 - cos2 * np.dot(d, d)
        B = 2 * (np.dot(g, v0) * np.dot(g, d) - cos2 * np.dot(v0, d))
        Cq = np.dot(g, v0) ** 2 - cos2 * np.dot(v0, v0)
        if A == 0:
            roots = [-Cq / B] if B != 0 else []
        else:
            disc = B * B - 4 * A * Cq
            roots = [] if disc < 0 else [(-B - np.sqrt(disc)) / (2 * A), (-B + np.sqrt(disc)) / (2 * A)]
        edge |= any(0 <= w <= 1 and np.dot(g, v0 + w * d) >= 0 for w in roots)
    # the axis ray against the triangle: solve C + s g = p1 + u (p2 - p1) + v (p3 - p1)
    M = np.column_stack([g, p1 - p2, p1 - p3])
    axis = False
    if abs(np.linalg.det(M)) > 0:
        s, u, v = np.linalg.solve(M, p1 - C)
        axis = s >= 0 and u >= 0 and v >= 0 and u + v <= 1
    return corner, edge, bool(axis), False


LDT_TABLE = [(2, -1, 1, -1), (2, 1, 1, -1), (0, 1, 2, 1), (0, 1, 2, -1), (0, 1, 1, -1), (0, -1, 1, -1)]


def naive_ldt_pixel(P, N, eye, tri, region, use_regions, W, depth, back, count, mismatch, is_open, R, n_lin, tau,
                    max_faces, dt, view_dir=None):
    """The LDT search of one pixel, written out from docs/ldt.md in plain Python on ``dt`` scalars
    (every operation rounded in ``dt``, in the contract's order). Arrays as the kernel's
    (``depth`` (K, 6, L, R, R) float32, ``back`` in ``dt``, ``W`` (K, 4, 4) in ``dt``).
    Returns a dict of the pixel's outputs (see refsoft.ldt.search.PixelSearch)."""
    one, zero, half, two = dt(1), dt(0), dt(0.5), dt(2)
    Rf = dt(R)
    P = [dt(x) for x in P]
    N = [dt(x) for x in N]
    if view_dir is not None:
        I = [dt(x) for x in view_dir]
    else:
        d = [P[i] - dt(eye[i]) for i in range(3)]
        length = np.sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2])
        I = [x / length for x in d]
    k2 = two * ((N[0] * I[0] + N[1] * I[1]) + N[2] * I[2])
    r = [I[i] - k2 * N[i] for i in range(3)]

    def int_margin(x):
        k = np.floor(x + half)
        return abs(x - k) if zero < k < Rf else one

    def texel(q0, u, s, f):
        q = [q0[i] + s * u[i] for i in range(3)]
        sa, ss, ta, ts = LDT_TABLE[f]
        sc = q[sa] if ss > 0 else -q[sa]
        tc = q[ta] if ts > 0 else -q[ta]
        x = ((sc + one) * half) * Rf
        y = ((tc + one) * half) * Rf
        col = min(max(int(np.floor(x)), 0), R - 1)
        row = R - 1 - min(max(int(np.floor(y)), 0), R - 1)
        h = half * (one - q[f // 2]) if f % 2 == 0 else half * (one + q[f // 2])
        return row, col, h, min(int_margin(x), int_margin(y))

    def face_search(q0, u, s_in, s_out, umax, f, k):
        n = n_lin if n_lin > 0 else min(max(int(np.ceil(((umax * (s_out - s_in)) * Rf) * half)), 1), 4 * R)
        D = (s_out - s_in) / dt(n)
        margin = one
        found = None
        was_front = False  # an open sheet is entered only from in front of it (the crossing rule)
        for m in range(n + 1):
            row, col, h, mt = texel(q0, u, s_in + dt(m) * D, f)
            margin = min(margin, mt)
            front = False
            for j in range(int(count[k, f, row, col])):
                z = dt(depth[k, f, j, row, col])
                margin = min(margin, abs(h - z))
                if h < z:
                    front = True
                    break
                dd = back[k, f, j, row, col]
                margin = min(margin, abs(h - dd))
                if h <= dd:
                    if was_front or not is_open[k]:
                        found = j
                    break
            if found is not None:
                break
            was_front = front
        samples = m + 1
        if found is None:
            return None, samples, 0, margin
        j = found
        if m == 0:
            return (s_in, j, row, col, (h - dt(depth[k, f, j, row, col])) * Rf, True), samples, 0, margin
        lo, hi = s_in + dt(m - 1) * D, s_in + dt(m) * D
        length, steps = ((D * umax) * Rf) * half, 0
        while length > dt(0.125) and steps < 16:
            length, steps = length * half, steps + 1
        best = (row, col, h)
        for _ in range(steps):
            mid = half * (lo + hi)
            rr, cc, hm, mt = texel(q0, u, mid, f)
            margin = min(margin, mt)
            inside = False
            if j < int(count[k, f, rr, cc]):
                z, dd = dt(depth[k, f, j, rr, cc]), back[k, f, j, rr, cc]
                margin = min(margin, abs(hm - z), abs(hm - dd))
                inside = z <= hm <= dd
            if inside:
                hi, best = mid, (rr, cc, hm)
            else:
                lo = mid
        e = (best[2] - dt(depth[k, f, j, best[0], best[1]])) * Rf
        return (hi, j, best[0], best[1], e, False), samples, steps, margin

    K = len(W)
    out = dict(ray=r, flags=0, samples=0, steps=0, faces=0, objects=0, object_distance=[-one] * K)
    best = None
    any_margin = one
    for k in range(K):
        q0 = [((W[k][i][0] * P[0] + W[k][i][1] * P[1]) + W[k][i][2] * P[2]) + W[k][i][3] for i in range(3)]
        u = [(W[k][i][0] * r[0] + W[k][i][1] * r[1]) + W[k][i][2] * r[2] for i in range(3)]
        nears, fars, miss = {}, [], False
        for i in range(3):
            if u[i] == zero:
                miss |= abs(q0[i]) > one
                continue
            a, b = sorted([(-one - q0[i]) / u[i], (one - q0[i]) / u[i]])
            nears[i] = a
            fars.append(b)
        if miss or not nears:
            continue
        near = max(nears.values())
        s_in, s_out = max(zero, near), min(fars)
        if not s_in < s_out:
            continue
        if use_regions and not region[tri][k]:
            out["flags"] |= 8
            continue
        out["objects"] += 1
        entry = min(i for i in nears if nears[i] == near) if near > zero else None
        if entry is None:
            out["flags"] |= 32
        rest = sorted((i for i in nears if i != entry), key=lambda i: (-abs(u[i]), i))
        order = ([entry] if entry is not None else []) + rest
        umax = max(abs(u[0]), abs(u[1]), abs(u[2]))
        chosen, accepted = None, False
        for a in order[:max_faces]:
            f = 2 * a + (1 if u[a] > zero else 0)
            res, samples, steps, margin = face_search(q0, u, s_in, s_out, umax, f, k)
            out["faces"] += 1
            out["samples"] += samples
            out["steps"] += steps
            any_margin = min(any_margin, margin)
            if res is None:
                continue
            if res[4] <= dt(tau):
                chosen, accepted = (res, f, margin), True
                break
            if chosen is None or res[4] < chosen[0][4]:
                chosen = (res, f, margin)
        if chosen is None:
            continue
        (s_hit, j, row, col, e, start), f, margin = chosen
        out["object_distance"][k] = s_hit
        if best is None or s_hit < best["distance"]:
            best = dict(distance=s_hit, object=k, face=f, layer=j, texel=(row, col), residual=e, margin=margin,
                        hit_flags=(1 if start else 0) | (0 if accepted else 2))
    if best is None:
        out.update(distance=-one, object=-1, face=-1, layer=-1, texel=(-1, -1), residual=zero, margin=any_margin,
                   hit=[zero] * 3)
        return out
    k, f, (row, col) = best["object"], best["face"], best["texel"]
    flags = best.pop("hit_flags") | (4 if mismatch[k, f, row, col] else 0) | (16 if is_open[k] else 0)
    out.update(best)
    out["flags"] |= flags
    out["hit"] = [P[i] + best["distance"] * r[i] for i in range(3)]
    return out

# ----------------------------------------------------------------------- environment map
def naive_cube_lookup(r, resolution):
    """One direction at a time, GL's cube-map selection table written out (GL spec section
    8.13), ties z over y over x, the positive face when the sign bit is clear, nearest texel
    (row 0 at the top); arithmetic in r's dtype. Returns (face, row, col) lists."""
    dt = np.asarray(r).dtype.type
    faces, rows, cols = [], [], []
    for rx, ry, rz in np.asarray(r):
        ax, ay, az = abs(rx), abs(ry), abs(rz)
        if az >= ax and az >= ay:
            if not np.signbit(rz):
                face, sc, tc, ma = 4, rx, -ry, az
            else:
                face, sc, tc, ma = 5, -rx, -ry, az
        elif ay >= ax:
            if not np.signbit(ry):
                face, sc, tc, ma = 2, rx, rz, ay
            else:
                face, sc, tc, ma = 3, rx, -rz, ay
        else:
            if not np.signbit(rx):
                face, sc, tc, ma = 0, -rz, -ry, ax
            else:
                face, sc, tc, ma = 1, rz, -ry, ax
        s = (dt(sc) / dt(ma) + dt(1)) * dt(0.5)
        t = (dt(tc) / dt(ma) + dt(1)) * dt(0.5)
        i = min(max(int(np.floor(s * dt(resolution))), 0), resolution - 1)
        j = min(max(int(np.floor(t * dt(resolution))), 0), resolution - 1)
        faces.append(face)
        rows.append(resolution - 1 - j)
        cols.append(i)
    return faces, rows, cols


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


# ------------------------------------------------------------------------------------ meshes
def naive_boundary_edges(vertices, faces):
    """Edges used by exactly one triangle after welding vertices whose positions round to the
    same point at 1e-9 of the extent, degenerate edges ignored: np.unique of rows, axis=0."""
    v = np.asarray(vertices, dtype=np.float64)
    extent = float(np.max(v.max(axis=0) - v.min(axis=0))) or 1.0
    _, weld = np.unique(np.round((v - v.min(axis=0)) / (extent * 1e-9)), axis=0, return_inverse=True)
    f = weld.reshape(-1)[np.asarray(faces, dtype=np.int64)]
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    _, counts = np.unique(e, axis=0, return_counts=True)
    return int(np.sum(counts == 1))
