"""The plain Python version of the candidates of refsoft/search/several.py (per-face loops over
sets and dicts), kept as the reference its vectorized version is checked against bit for bit."""

import numpy as np

from refsoft import constants
from refsoft.errors import RefsoftError
from refsoft.search import search
from refsoft.search.images import Images
from refsoft.search.several import Candidates, sheets


def links(gb, eye, verts, images: Images, edges, neighbourhood="cross", cap=None) -> np.ndarray:
    """Mutually linked images across edges (spec section 4.8 sheets).

    Parameters
    ----------
    gb : GBuffer
    eye : (3,) float64
    verts : (N, 3) float64
        The vertices ``images`` holds images of.
    images : Images
    edges : (E, 2) int64
        Vertex index pairs.
    neighbourhood, cap
        The walk's options (:func:`refsoft.search.search`).

    Returns
    -------
    (L, 2) int64
        Image index pairs (i, j), ``i`` an image of the edge's first vertex, ``j`` of its second,
        sorted by (i, j).
    """
    edges = np.asarray(edges, np.int64).reshape(-1, 2)
    if len(edges) == 0 or len(images.pixel) == 0:
        return np.zeros((0, 2), np.int64)
    fwd = _walks(gb, eye, verts, images, edges, neighbourhood, cap)
    back = _walks(gb, eye, verts, images, edges[:, ::-1], neighbourhood, cap)
    f = set(map(tuple, fwd.tolist()))
    pairs = sorted(p for p in map(tuple, back[:, ::-1].tolist()) if p in f)
    return np.asarray(pairs, np.int64).reshape(-1, 2)


def _walks(gb, eye, verts, images, edges, neighbourhood, cap):
    """(i, j) pairs: the walk of edge end b started at image i of end a ends at b's image j."""
    off = images.offset
    a, b = edges[:, 0], edges[:, 1]
    na = off[a + 1] - off[a]
    rep = np.repeat(np.arange(len(edges)), na)
    if len(rep) == 0:
        return np.zeros((0, 2), np.int64)
    first = np.repeat(off[a], na)
    i = first + (np.arange(len(rep)) - np.repeat(np.cumsum(na) - na, na))
    target = b[rep]
    res = search(gb, eye, verts[target], neighbourhood, "plane", images.pixel[i], cap)
    # each walk's end against every image of its target: the nearest (Chebyshev, the first of
    # equals) within SEVERAL_LINK_TEXELS
    nt = off[target + 1] - off[target]
    walk = np.repeat(np.arange(len(i)), nt)
    if len(walk) == 0:
        return np.zeros((0, 2), np.int64)
    j = np.repeat(off[target], nt) + (np.arange(len(walk)) - np.repeat(np.cumsum(nt) - nt, nt))
    d = np.max(np.abs(images.pixel[j].astype(np.int64) - res.pixel[walk].astype(np.int64)), axis=1)
    order = np.lexsort((j, d, walk))  # by walk, then distance, then image index
    walk, j, d = walk[order], j[order], d[order]
    first = np.ones(len(walk), bool)
    first[1:] = walk[1:] != walk[:-1]
    keep = first & (d <= constants.SEVERAL_LINK_TEXELS)
    return np.stack([i[walk[keep]], j[keep]], axis=1).astype(np.int64).reshape(-1, 2)


def candidates(gb, eye, verts, normals, faces, face_obj, images: Images, find, neighbourhood="cross", cap=None,
               max_level=None):
    """Candidate virtual triangles of every scene triangle (module docstring, step 2).

    Parameters
    ----------
    gb : GBuffer
    eye : (3,) float64
    verts, normals : (N, 3) float64
        The reflected vertices and their unit normals.
    faces : (F, 3) int64
    face_obj : (F,) int32
    images : Images
        Every image of ``verts``.
    find : callable
        ``find(points (K, 3) float64) -> Images``: every image of new points (midpoints).
    max_level : int, optional
        Subdivision levels (default ``constants.SEVERAL_MAX_LEVEL``).

    Returns
    -------
    Candidates, Images
        The candidates, and ``images`` with its sheets (from the links of the scene's edges).
    """
    max_level = constants.SEVERAL_MAX_LEVEL if max_level is None else int(max_level)
    if max_level < 0:
        raise RefsoftError(f"max_level must be >= 0, got {max_level}")
    verts = np.asarray(verts, np.float64)
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    pool = _Pool(verts, np.asarray(normals, np.float64), images)
    edges = _edges(faces)
    pairs = links(gb, eye, verts, images, edges, neighbourhood, cap)
    with_sheets = sheets(images, pairs)
    pool.add_links(pairs)
    pool.walked.update(map(tuple, edges.tolist()))
    out = []
    todo_faces, todo_src = faces, np.arange(len(faces), dtype=np.int64)
    subdivided = set()
    for level in range(max_level + 1):
        last = level == max_level
        split, bare = [], []
        for f, src in zip(todo_faces, todo_src):
            triples = pool.triples(f, linked=True)
            out.extend((t, f, src) for t in triples)
            if not pool.matched(f, triples):  # a part of it may reflect where no linked triple draws it
                (bare if last else split).append((f, src))
        if last and bare:
            out.extend(pool.rim_triples(bare, gb, eye, neighbourhood, cap))
        if not split:
            break
        subdivided.update(int(s) for _, s in split)
        todo_faces, todo_src = pool.split(split, gb, eye, find, neighbourhood, cap)
    return pool.candidates(out, face_obj, len(subdivided)), with_sheets


def _edges(faces):
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e = np.sort(e, axis=1)
    return np.unique(e, axis=0)


class _Pool:
    """Vertices (scene vertices, then midpoints), their images and the links between images."""

    def __init__(self, verts, normals, images):
        self.verts, self.normals = [verts], [normals]
        self.n = len(verts)
        self.offset = list(images.offset[:-1])
        self.count = list(np.diff(images.offset))
        self.pixel, self.virtual = [images.pixel], [images.virtual]
        self.m = len(images.pixel)
        self.linked = set()
        self.walked = set()  # edges whose links are known
        self.midpoint = {}

    def add_links(self, pairs):
        for i, j in pairs.tolist():
            self.linked.add((min(i, j), max(i, j)))

    def _images(self, v):
        return range(self.offset[v], self.offset[v] + self.count[v])

    def triples(self, f, linked):
        a, b, c = (int(x) for x in f)
        out = []
        for i in self._images(a):
            for j in self._images(b):
                if linked and (min(i, j), max(i, j)) not in self.linked:
                    continue
                for k in self._images(c):
                    if linked and ((min(j, k), max(j, k)) not in self.linked
                                   or (min(i, k), max(i, k)) not in self.linked):
                        continue
                    out.append((i, j, k))
                    if len(out) >= constants.SEVERAL_MAX_TRIPLES:
                        return out
        return out

    def matched(self, f, triples):
        """Every image of every corner of face ``f`` belongs to one of its linked ``triples``."""
        used = {i for t in triples for i in t}
        return all(self.count[int(v)] > 0 and all(i in used for i in self._images(int(v))) for v in f)

    def rim_triples(self, bare, gb, eye, neighbourhood, cap):
        """Triples for last-level parts with an image in no linked triple: every image of each corner,
        and for a corner without one the pixels where its walks from the other corners' images
        end (at the rim or a fold), as points of the reflector (a virtual vertex projects where
        its reflection point does: these serve only to rasterize; the acceptance is exact)."""
        verts = np.concatenate(self.verts)
        starts, targets, keys = [], [], []
        for f, _ in bare:
            for v in f:
                if self.count[int(v)] == 0:
                    for u in f:
                        for i in self._images(int(u)):
                            starts.append(i)
                            targets.append(int(v))
                            keys.append((int(v), i))
        ends = {}
        if starts:
            pixel = np.concatenate(self.pixel)
            res = search(gb, eye, verts[targets], neighbourhood, "plane", pixel[starts], cap)
            world = np.asarray(gb.position, np.float64)[res.pixel[:, 0], res.pixel[:, 1]] + gb.origin
            ok = np.asarray(gb.mask)[res.pixel[:, 0], res.pixel[:, 1]]
            new = []
            for key, p, good in zip(keys, world, ok):
                if good:
                    ends.setdefault(key[0], []).append(self.m + len(new))
                    new.append(p)
            if new:
                self.virtual.append(np.asarray(new, np.float64))
                self.pixel.append(np.zeros((len(new), 2), np.int32))
                self.m += len(new)
        out = []
        for f, src in bare:
            choices = [list(self._images(int(v))) or sorted(set(ends.get(int(v), []))) for v in f]
            triples = []
            for i in choices[0]:
                for j in choices[1]:
                    for k in choices[2]:
                        if len(triples) < constants.SEVERAL_MAX_TRIPLES:
                            triples.append((i, j, k))
            out.extend((t, f, src) for t in triples)
        return out

    def split(self, split, gb, eye, find, neighbourhood, cap):
        """Cut each face at its edge midpoints (shared between faces); find the new points'
        images and link the new edges. Returns the parts and their scene triangles."""
        verts = np.concatenate(self.verts)
        normals = np.concatenate(self.normals)
        new_keys, new_p, new_n = [], [], []
        parts, src = [], []
        for f, s in split:
            a, b, c = (int(x) for x in f)
            mids = []
            for p, q in ((a, b), (b, c), (c, a)):
                key = (min(p, q), max(p, q))
                if key not in self.midpoint:
                    self.midpoint[key] = self.n + len(new_keys)
                    new_keys.append(key)
                    new_p.append(0.5 * (verts[p] + verts[q]))
                    nm = normals[p] + normals[q]
                    length = np.sqrt(np.sum(nm * nm))
                    new_n.append(nm / length if length > 0 else nm)
                mids.append(self.midpoint[key])
            ab, bc, ca = mids
            parts += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
            src += [s] * 4
        if new_keys:
            pts = np.asarray(new_p, np.float64)
            found = find(pts)
            self.verts.append(pts)
            self.normals.append(np.asarray(new_n, np.float64))
            self.offset += [self.m + int(o) for o in found.offset[:-1]]
            self.count += [int(c) for c in np.diff(found.offset)]
            self.pixel.append(found.pixel)
            self.virtual.append(found.virtual)
            self.m += len(found.pixel)
            self.n += len(pts)
        parts = np.asarray(parts, np.int64).reshape(-1, 3)
        # link the parts' edges over every vertex so far (the walk needs every image)
        allv = np.concatenate(self.verts)
        images = Images(np.asarray(self.offset + [self.m], np.int64), np.concatenate(self.pixel),
                        np.concatenate(self.virtual), np.full(self.m, -1, np.int32))
        edges = _edges(parts)
        fresh = np.array([tuple(e) not in self.walked for e in edges.tolist()], bool).reshape(-1)
        self.walked.update(map(tuple, edges.tolist()))
        self.add_links(links(gb, eye, allv, images, edges[fresh], neighbourhood, cap))
        return parts, np.asarray(src, np.int64)

    def candidates(self, out, face_obj, subdivided):
        verts = np.concatenate(self.verts)
        normals = np.concatenate(self.normals)
        virtual = np.concatenate(self.virtual).reshape(-1, 3)
        c = len(out)
        tri_img = np.asarray([t for t, _, _ in out], np.int64).reshape(c, 3)
        f = np.asarray([f for _, f, _ in out], np.int64).reshape(c, 3)
        src = np.asarray([s for _, _, s in out], np.int64)
        return Candidates(virtual[tri_img], verts[f], normals[f], np.asarray(face_obj, np.int32)[src], src,
                          subdivided)


def accept(r0, c0, valid, origin, direction, screen, bbox, dilate, real):
    """The per-pixel acceptance of refsoft/search/_several.py in its plain form: every box pixel,
    every candidate in index order, row by row, with no skipping; the same float64 operations
    in the same order (Python floats are IEEE doubles).

    Returns best_t (h, w) float64, best_c (h, w) int64, best_uv (h, w, 2) float64, tested (h, w) bool.
    """
    import math

    h, w = valid.shape
    best_t = np.full((h, w), np.inf)
    best_c = np.full((h, w), -1, np.int64)
    best_uv = np.zeros((h, w, 2))
    tested = np.zeros((h, w), bool)
    for r in range(h):
        y = r + r0 + 0.5
        for c in range(len(screen)):
            if r < bbox[c, 0] or r >= bbox[c, 1]:
                continue
            (ax, ay), (bx, by), (cx, cy) = (tuple(float(v) for v in p) for p in screen[c])
            area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
            sign = 1.0 if area >= 0.0 else -1.0
            lab = math.sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay))
            lbc = math.sqrt((cx - bx) * (cx - bx) + (cy - by) * (cy - by))
            lca = math.sqrt((ax - cx) * (ax - cx) + (ay - cy) * (ay - cy))
            d = float(dilate[c])
            plain = d < 0.0 or abs(area) <= 1e-12 * (lab + lbc + lca) * (lab + lbc + lca)
            p0 = [float(v) for v in real[c, 0]]
            e1 = [float(real[c, 1, i]) - p0[i] for i in range(3)]
            e2 = [float(real[c, 2, i]) - p0[i] for i in range(3)]
            for col in range(max(bbox[c, 2], c0), min(bbox[c, 3], c0 + w)):
                j = col - c0
                if not valid[r, j]:
                    continue
                if not plain:
                    x = col + 0.5
                    fab = sign * ((bx - ax) * (y - ay) - (by - ay) * (x - ax))
                    fbc = sign * ((cx - bx) * (y - by) - (cy - by) * (x - bx))
                    fca = sign * ((ax - cx) * (y - cy) - (ay - cy) * (x - cx))
                    if fab < -d * lab or fbc < -d * lbc or fca < -d * lca:
                        continue
                tested[r, j] = True
                dx, dy, dz = (float(v) for v in direction[r, j])
                px, py, pz = dy * e2[2] - dz * e2[1], dz * e2[0] - dx * e2[2], dx * e2[1] - dy * e2[0]
                det = (e1[0] * px + e1[1] * py) + e1[2] * pz
                if det == 0.0:
                    continue
                inv = 1.0 / det
                sx, sy, sz = (float(origin[r, j, i]) - p0[i] for i in range(3))
                u = ((sx * px + sy * py) + sz * pz) * inv
                if u < 0.0 or u > 1.0:
                    continue
                qx, qy, qz = sy * e1[2] - sz * e1[1], sz * e1[0] - sx * e1[2], sx * e1[1] - sy * e1[0]
                v = ((dx * qx + dy * qy) + dz * qz) * inv
                if v < 0.0 or u + v > 1.0:
                    continue
                t = ((e2[0] * qx + e2[1] * qy) + e2[2] * qz) * inv
                if t > 0.0 and t < best_t[r, j]:
                    best_t[r, j], best_c[r, j], best_uv[r, j] = t, c, (u, v)
    return best_t, best_c, best_uv, tested
