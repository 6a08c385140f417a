"""What ``refsoft check``'s rules need from the oracle itself for one case and frame: the
scene, the vertices searched, the scene's extent, each reflector's G-buffer as the search saw
it, and the geometry behind the G-buffer rules' tolerances (fragments, edges, the next fragment
at a depth tie). Built on demand by :meth:`refsoft.conformance.findings.Context.oracle`."""

from __future__ import annotations

import numpy as np

from .profiles import edge_triangles, fragments


class Oracle:
    """What the rules need from the oracle itself for one case and frame (built on demand):
    the scene, vertices, extent, and each reflector's G-buffer as the search saw it."""

    def __init__(self, entry, frame):
        from .golden import Case
        from ..scene import scene_vertices

        self.entry, self.frame = entry, frame
        self.case = Case(entry["name"], entry["scene"], tuple(entry["frames"]), options_of(entry["options"]))
        self.scene = self.case.load()
        self.verts, _ = scene_vertices(self.scene, frame)
        allv = np.concatenate([self.scene.world_mesh(k, frame).vertices for k in range(1, len(self.scene.objects) + 1)])
        self.extent = float(np.linalg.norm(allv.max(axis=0) - allv.min(axis=0)))
        self._gb = {}

    def gbuffer(self, k):
        from ..search.reflect import reflector_gbuffer

        if k not in self._gb:
            o = self.case.options
            self._gb[k] = reflector_gbuffer(self.scene, k, self.frame, o.get("widen", 1.0), o.get("gbuffer_size"),
                                            o.get("precision", "float32"))
        return self._gb[k]

    def fragments(self, k, pixels, triangles=None):
        """:func:`refsoft.conformance.profiles.fragments` of reflector ``k``'s G-buffer at
        ``pixels`` (n, 2): of the G-buffer's own triangles there, or of ``triangles`` (n,)."""
        gb = self.gbuffer(k)
        pixels = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
        tri = gb.triangle[pixels[:, 0], pixels[:, 1]] if triangles is None else triangles
        h, w = gb.mask.shape
        return fragments(self.scene.world_mesh(k, self.frame, proxy=True), gb.view_proj, w, h, pixels, tri)

    def edge_triangles(self, k, pixels, distance):
        """:func:`refsoft.conformance.profiles.edge_triangles` of reflector ``k``'s G-buffer."""
        gb = self.gbuffer(k)
        h, w = gb.mask.shape
        return edge_triangles(self.scene.world_mesh(k, self.frame, proxy=True), gb.view_proj, w, h, pixels, distance)

    def second_fragment(self, k):
        """Reflector ``k``'s next fragment behind the G-buffer's, as saved maps: world-space
        float32 positions and float32 normals (H, W, 3), zero where there is none, and its
        triangles (H, W; -1 where none) (:func:`refsoft.raster.gbuffer_layers`)."""
        from ..raster import gbuffer_layers

        key = ("second", k)
        if key not in self._gb:
            gb = self.gbuffer(k)
            h, w = gb.mask.shape
            sec = gbuffer_layers(self.scene.world_mesh(k, self.frame, proxy=True), gb.view_proj, w, h,
                                 gb.position.dtype.name, gb.origin)
            has = sec.triangle >= 0
            pos = np.where(has[..., None], sec.position.astype(np.float64) + gb.origin, 0.0).astype(np.float32)
            self._gb[key] = (pos, sec.normal.astype(np.float32), sec.triangle)
        return self._gb[key]

    def edge_distance(self, k, pixels):
        """Distance (px) from each pixel centre (row, col) to the nearest edge of the reflector's
        projected triangles, unsnapped float64 window coordinates."""
        from ..search.reflect import gbuffer_camera

        o = self.case.options
        cam = gbuffer_camera(self.scene, self.frame, o.get("widen", 1.0), o.get("gbuffer_size"))
        mesh = self.scene.world_mesh(k, self.frame, proxy=True)
        clip = np.c_[mesh.vertices, np.ones(mesh.n_vertices)] @ cam.view_proj().T
        front = clip[:, 3] > 0
        win = np.zeros((mesh.n_vertices, 2))
        win[front] = np.c_[(clip[front, 0] / clip[front, 3] + 1) * 0.5 * cam.width,
                           (clip[front, 1] / clip[front, 3] + 1) * 0.5 * cam.height]
        f = mesh.faces[np.all(front[mesh.faces], axis=1)]
        a = np.concatenate([win[f[:, 0]], win[f[:, 1]], win[f[:, 2]]])
        b = np.concatenate([win[f[:, 1]], win[f[:, 2]], win[f[:, 0]]])
        out = np.full(len(pixels), np.inf)
        for i, (r, c) in enumerate(pixels):
            p = np.array([c + 0.5, cam.height - 1 - r + 0.5])
            ab = b - a
            t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
            out[i] = np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)) if len(a) else np.inf
        return out


def options_of(d):
    """A manifest entry's options with its JSON lists as tuples (as :class:`refsoft.RenderOptions` holds them)."""
    return {k: (tuple(v) if isinstance(v, list) else v) for k, v in d.items()}
