"""Plain NumPy reference of every reflection point of a vertex (spec section 4.8): every covered
texel of the G-buffer judged by the definition, no pruning. Slow; for small G-buffers in tests."""

import numpy as np


def _normalize(x):
    """refsoft's normalize in x's precision: ``x * (1 / sqrt((x.x x.x + x.y x.y) + x.z x.z))``, 0 for 0."""
    length = np.sqrt((x[..., 0] * x[..., 0] + x[..., 1] * x[..., 1]) + x[..., 2] * x[..., 2])
    one = x.dtype.type(1)
    inv = np.where(length > 0, one / np.where(length > 0, length, one), x.dtype.type(0)).astype(x.dtype)
    return x * inv[..., None]


def scores(P, N, mask, eye_rel, v_rel):
    """The score of spec section 4.1 at every texel (H, W), in P's precision; -3 where uncovered."""
    u = _normalize((eye_rel - P).astype(P.dtype))
    b = _normalize((v_rel - P).astype(P.dtype))
    h = _normalize(u + b)
    s = (N[..., 0] * h[..., 0] + N[..., 1] * h[..., 1]) + N[..., 2] * h[..., 2]
    return np.where(mask, s, P.dtype.type(-3)), u


def _unit64(x):
    n = np.sqrt((x[..., 0] * x[..., 0] + x[..., 1] * x[..., 1]) + x[..., 2] * x[..., 2])
    return np.where(n[..., None] > 0, x / np.where(n > 0, n, 1.0)[..., None], x)


def newton_step(P, N, U, mask, v_rel, r, c):
    """One Newton step on ``h - N = 0`` from texel (r, c) (float64, as the kernel's): (d_row,
    d_col), or None when an axis has no covered neighbour or the Jacobian is singular."""
    got = jacobian(P, N, U, mask, v_rel, r, c, with_residual=True)
    if got is None:
        return None
    r0, cols = got
    (jc0, jc1), (jr0, jr1) = cols
    det = jc0 * jr1 - jr0 * jc1
    if det == 0.0 or not np.isfinite(det):
        return None
    d_col = (-r0[0] * jr1 + r0[1] * jr0) / det
    d_row = (-r0[1] * jc0 + r0[0] * jc1) / det
    if not (np.isfinite(d_col) and np.isfinite(d_row)):
        return None
    return d_row, d_col


def _reflected(U, N):
    """The reflected eye ray ``I - 2 (N.I) N``, ``I = -U``, float64."""
    i = -U.astype(np.float64)
    n = N.astype(np.float64)
    return i - 2.0 * np.sum(n * i, axis=-1, keepdims=True) * n


def reaches(P, N, U, mask, v_rel, r, c, factor=2.5):
    """Texel (r, c)'s reflected ray can reach the vertex (float64): within ``factor`` times the
    largest angle to a covered 3x3 neighbour's reflected ray, its apex anywhere within
    ``factor`` times the largest distance to a neighbour's point."""
    h, w = mask.shape
    p, a = P[r, c].astype(np.float64), _reflected(U[r, c], N[r, c])
    rad = ang = 0.0
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            rr, cc = r + dr, c + dc
            if (dr, dc) == (0, 0) or not (0 <= rr < h and 0 <= cc < w and mask[rr, cc]):
                continue
            rad = max(rad, np.linalg.norm(P[rr, cc].astype(np.float64) - p))
            b = _reflected(U[rr, cc], N[rr, cc])
            ang = max(ang, np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b))
    rad, ang = factor * rad, factor * ang
    d = np.asarray(v_rel, dtype=np.float64) - p
    dist = np.linalg.norm(d)
    if dist <= rad:
        return True
    off = np.arctan2(np.linalg.norm(np.cross(d, a)), d @ a)
    return off <= min(ang, np.pi) + np.arcsin(min(rad / dist, 1.0))


def converge(P, N, U, mask, v_rel, r, c, reach=4.0, tol=0.75, steps=8, factor=2.5, path=None):
    """Newton's iteration texel to texel from (r, c) (spec section 4.8): ((image row, image col),
    (converged row, col)) when a step, or the move of the step's point from the last one (from
    (r, c) at first), is at most ``tol`` texels within ``steps`` steps, or the iteration steps
    back to the neighbour it came from (the point is then the middle of the two), every point within
    ``reach`` texels of (r, c) and every texel stepped to covered, and the image (the covered
    texel nearest the point, else the one stepped from) has the vertex in front and reaches it;
    None otherwise. ``path``, a list, receives each step's (texel, point)."""
    h, w = mask.shape
    cr, cc, lr, lc = r, c, float(r), float(c)
    prev = None
    for _ in range(steps):
        step = newton_step(P, N, U, mask, v_rel, cr, cc)
        if step is None:
            return None
        point = (cr + step[0], cc + step[1])
        done = step[0] ** 2 + step[1] ** 2 <= tol * tol or (point[0] - lr) ** 2 + (point[1] - lc) ** 2 <= tol * tol
        nr, nc = int(np.floor(point[0] + 0.5)), int(np.floor(point[1] + 0.5))
        if not done and (nr, nc) == prev and abs(cr - prev[0]) <= 1 and abs(cc - prev[1]) <= 1:
            done = True  # back to the neighbour it came from: the middle of the two points
            lr, lc = (lr + point[0]) * 0.5, (lc + point[1]) * 0.5
            nr, nc = int(np.floor(lr + 0.5)), int(np.floor(lc + 0.5))
        else:
            lr, lc = point
        if path is not None:
            path.append(((cr, cc), (lr, lc)))
        if (lr - r) ** 2 + (lc - c) ** 2 > reach * reach:
            return None
        inside = 0 <= nr < h and 0 <= nc < w and mask[nr, nc]
        if done:
            if inside:
                cr, cc = nr, nc
            d = (v_rel - P[cr, cc]).astype(P.dtype)
            n = N[cr, cc]
            if not ((d[0] * n[0] + d[1] * n[1]) + d[2] * n[2]) > 0:
                return None
            if not reaches(P, N, U, mask, v_rel, cr, cc, factor):
                return None
            return (cr, cc), (lr, lc)
        if not inside:
            return None
        prev = (cr, cc)
        cr, cc = nr, nc
    return None


def jacobian(P, N, U, mask, v_rel, r, c, with_residual=False):
    """The 2x2 Jacobian of the residual at texel (r, c) by central differences, one-sided beside
    an uncovered texel (columns: along the columns, along the rows; with ``with_residual`` also
    the residual there, first); None when an axis has no covered neighbour."""
    h_, w_ = mask.shape
    n = N[r, c].astype(np.float64)
    a = np.abs(n)
    e = np.eye(3)[0 if (a[0] <= a[1] and a[0] <= a[2]) else (1 if a[1] <= a[2] else 2)]
    t0 = np.cross(n, e)
    t0 = t0 / np.sqrt((t0[0] * t0[0] + t0[1] * t0[1]) + t0[2] * t0[2])
    t = np.stack([t0, np.cross(n, t0)])

    def res(rr, cc):
        b = _unit64(np.asarray(v_rel, dtype=np.float64) - P[rr, cc].astype(np.float64))
        d = _unit64(U[rr, cc].astype(np.float64) + b) - N[rr, cc].astype(np.float64)
        return np.array([(d[0] * t[k, 0] + d[1] * t[k, 1]) + d[2] * t[k, 2] for k in range(2)])

    def cov(rr, cc):
        return 0 <= rr < h_ and 0 <= cc < w_ and mask[rr, cc]

    r0 = res(r, c)
    cols = []
    for dr, dc in ((0, 1), (1, 0)):
        fa, fb = cov(r + dr, c + dc), cov(r - dr, c - dc)
        if fa and fb:
            cols.append((res(r + dr, c + dc) - res(r - dr, c - dc)) * 0.5)
        elif fa:
            cols.append(res(r + dr, c + dc) - r0)
        elif fb:
            cols.append(r0 - res(r - dr, c - dc))
        else:
            return None
    return (r0, cols) if with_residual else cols


def fold_seeds(P, N, U, mask, v_rel, cand, reach=4.0, merge=1.0, ratio=0.1, steps=6):
    """The candidates (score, image row, col, converged row, col) beside a fold (spec section
    4.9): from each candidate's image (in the order of image row, col, converged row, col) whose
    Jacobian is nearly singular, Newton's iteration from
    the texels 2 .. ``steps`` along its null direction (both ways), kept when accepted at least
    ``merge`` from every candidate so far and on another texel."""
    out = []
    h, w = mask.shape
    every = list(cand)
    for _, ir, ic, lr, lc in sorted(cand, key=lambda e: (e[1], e[2], e[3], e[4])):  # image texel, then point
        cols = jacobian(P, N, U, mask, v_rel, ir, ic)
        if cols is None:
            continue
        (jc0, jc1), (jr0, jr1) = cols
        aa, bb, cc = jc0 * jc0 + jc1 * jc1, jc0 * jr0 + jc1 * jr1, jr0 * jr0 + jr1 * jr1
        det = jc0 * jr1 - jr0 * jc1
        if not (aa + cc > 0.0 and abs(det) < ratio * (aa + cc)):
            continue
        half = (aa - cc) * 0.5
        lam = (aa + cc) * 0.5 - np.sqrt(half * half + bb * bb)
        x, y = (bb, lam - aa), (lam - cc, bb)
        dc, dr = x if x[0] * x[0] + x[1] * x[1] >= y[0] * y[0] + y[1] * y[1] else y
        n = np.sqrt(dc * dc + dr * dr)
        if not n > 0.0:
            continue
        dc, dr = dc / n, dr / n
        for k in range(2, steps + 1):
            for sign in (1.0, -1.0):
                sr, sc = int(np.floor(lr + sign * k * dr + 0.5)), int(np.floor(lc + sign * k * dc + 0.5))
                if not (0 <= sr < h and 0 <= sc < w and mask[sr, sc]):
                    continue
                d = (np.asarray(v_rel) - P[sr, sc]).astype(P.dtype)
                nn = N[sr, sc]
                if not ((d[0] * nn[0] + d[1] * nn[1]) + d[2] * nn[2]) > 0:
                    continue
                if not reaches(P, N, U, mask, v_rel, sr, sc):
                    continue
                got = converge(P, N, U, mask, v_rel, sr, sc, reach)
                if got is None:
                    continue
                (qr, qc), (pr, pc) = got
                if any((qr, qc) == (e[1], e[2]) or (pr - e[3]) ** 2 + (pc - e[4]) ** 2 < merge * merge for e in every):
                    continue
                score = _score_at(P, N, U, v_rel, sr, sc)
                entry = (score, qr, qc, pr, pc)
                every.append(entry)
                out.append(entry)
    return out


def _score_at(P, N, U, v_rel, r, c):
    """Texel (r, c)'s score in P's precision (:func:`scores` at one texel)."""
    b = _normalize((np.asarray(v_rel) - P[r, c]).astype(P.dtype)[None])[0]
    h = _normalize((U[r, c] + b)[None])[0]
    n = N[r, c]
    return float((n[0] * h[0] + n[1] * h[1]) + n[2] * h[2])


def images_of(P, N, mask, eye_rel, v_rel, first=(-1, -1), reach=4.0, merge=1.0):
    """Every image of one vertex, by judging every covered texel: a list of (row, col), the image
    of the walk's texel ``first`` first when it has one (``first`` covered, in front, its reflected
    ray reaching the vertex, Newton's iteration from it converging: the texel where it converged),
    then the others (each maximum's image: the
    texel where its iteration converged) in row-major order after merging (best score first, ties
    to the image's row then col; dropped when its image is a kept one's or its converged point is
    within ``merge`` of a kept one's)."""
    dt = P.dtype.type
    s, U = scores(P, N, mask, eye_rel, v_rel)
    h, w = mask.shape
    pad = np.full((h + 2, w + 2), dt(-3))
    pad[1:-1, 1:-1] = s
    nbr = np.max([pad[1 + dr:h + 1 + dr, 1 + dc:w + 1 + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1)
                  if (dr, dc) != (0, 0)], axis=0)
    d = (v_rel - P).astype(P.dtype)
    front = ((d[..., 0] * N[..., 0] + d[..., 1] * N[..., 1]) + d[..., 2] * N[..., 2]) > 0
    cand = []
    for r, c in zip(*np.nonzero(mask & (s >= nbr) & front)):
        if not reaches(P, N, U, mask, v_rel, r, c):
            continue
        got = converge(P, N, U, mask, v_rel, r, c, reach)
        if got is not None:
            (ir, ic), (lr, lc) = got
            cand.append((float(s[r, c]), ir, ic, lr, lc))
    cand = cand + fold_seeds(P, N, U, mask, v_rel, cand, reach, merge)
    kept = []
    fr, fc = first
    if fr >= 0 and mask[fr, fc] and front[fr, fc] and reaches(P, N, U, mask, v_rel, fr, fc):
        got = converge(P, N, U, mask, v_rel, fr, fc, reach)
        if got is not None:
            kept.append((None, got[0][0], got[0][1], got[1][0], got[1][1]))
    for sc, r, c, lr, lc in sorted(cand, key=lambda x: (-x[0], x[1], x[2])):
        if any((r, c) == (k[1], k[2]) or (lr - k[3]) ** 2 + (lc - k[4]) ** 2 < merge * merge for k in kept):
            continue
        kept.append((sc, r, c, lr, lc))
    head = [k for k in kept if k[0] is None]
    rest = sorted((k for k in kept if k[0] is not None), key=lambda x: (x[1], x[2]))
    return [(k[1], k[2]) for k in head + rest]


def count_images(P, N, mask, eye_rel, vertices_rel, firsts=None):
    """:func:`images_of` for each vertex: a list of lists of (row, col)."""
    out = []
    for i, v in enumerate(vertices_rel):
        first = (-1, -1) if firsts is None else tuple(int(x) for x in firsts[i])
        out.append(images_of(P, N, mask, eye_rel, np.asarray(v, dtype=P.dtype), first))
    return out
