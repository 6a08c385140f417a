"""The options of a render (:class:`RenderOptions`) and its presets, checked once at the boundary.

A preset names a set of options (:data:`PRESETS`); options given one by one override it:

- ``paper``: the papers' method verbatim (the crosshair walk from the bounding box's centre, the
  plane rule for hidden vertices, virtual vertices mirrored across the texel's tangent plane, no
  refinement, no tessellation). ``refsoft bench table1`` and the golden set's paper cases use it.
- ``accurate`` (the default): the configuration chosen by measurement against the ray-traced
  truth (docs/accuracy.md): the 3x3 walk, hidden vertices' triangles cut at the silhouette and
  their hidden part left out, sub-texel reflection points, virtual vertices unfolded onto the
  eye's ray, adaptive tessellation.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

from .constants import PRESET_NAMES

from . import validate
from . import constants
from .constants import (INVERSE_MODES, MAX_TESSELLATION_LEVEL, METHODS, NEIGHBOURHOODS, PRECISIONS, SKIPS,
                        SILHOUETTE_RULES, VIRTUAL_RULES)
from .errors import RefsoftError


class _FromPreset:
    """The default of the options a preset sets: "take the preset's value"."""

    def __repr__(self):
        return "FROM_PRESET"


#: Default of :class:`RenderOptions`' preset-controlled fields.
FROM_PRESET = _FromPreset()

#: The presets: every option each one sets (the others keep their defaults).
PRESETS = {
    "paper": dict(method="walk", neighbourhood="cross", inverse="plane", refine=False, tessellate=None, max_level=3,
                  tessellate_span=0, virtual="mirror", silhouette="texel", images="one", draw="raster",
                  border_restart=False),
    "accurate": dict(method="walk", neighbourhood="box", inverse="discard", refine=True, tessellate=1e-3, max_level=1,
                     tessellate_span=8, virtual="unfold", silhouette="clip", images="all", draw="exact",
                     border_restart=True),
}

#: The layered depth textures' options (``method="ldt"`` only) and their defaults.
LDT_DEFAULTS = dict(ldt_resolution=constants.LDT_RESOLUTION, ldt_layers="all", ldt_faces="three",
                    ldt_linear=constants.LDT_LINEAR_STEPS, ldt_tau=constants.LDT_TAU, ldt_regions="cone")
#: The environment map's options (``method="envmap"`` only) and their defaults.
ENVMAP_DEFAULTS = dict(envmap_resolution=constants.ENVMAP_RESOLUTION)
#: The per-pixel methods' own options: what each reads beside ``method`` and ``precision``.
METHOD_DEFAULTS = {"ldt": LDT_DEFAULTS, "envmap": ENVMAP_DEFAULTS}
_OWN_OPTIONS = {name for d in METHOD_DEFAULTS.values() for name in d}


@dataclass(frozen=True)
class RenderOptions:
    """Options of :func:`refsoft.render`: a preset, and options given one by one over it.

    Parameters
    ----------
    preset : {"accurate", "paper"}
        The options not given take this preset's values (:data:`PRESETS`; default
        ``accurate``).
    method : {"walk", "hierarchy"}
        The reflection method: the vertex search's linear walk from a start pixel (Estalella),
        or Szabo's ray-cone pyramid (no coherence).
    neighbourhood : {"cross", "box"}
        The walk's candidates per step: the crosshair or the 3x3 box.
    inverse : {"plane", "search", "discard"}
        Hidden vertices: Estalella's plane rule, the inverse search, or their triangles left out.
    widen : float
        Wider-frustum factor of the G-buffers (1.0: off).
    gbuffer_size : (int, int), optional
        G-buffer (width, height); default keeps the view's pixel density.
    precision : {"float32", "float64"}
    coherence : bool
        Start each search at the vertex's previous reflection pixel.
    border_restart : bool
        With coherence, a walk from the previous pixel that stops on the G-buffer's border
        (BORDER) with a score below ``constants.BORDER_RESTART_SCORE`` is walked again from the
        start without history (spec section 4.3) and the higher score kept (beyond the papers; ``paper`` off, ``accurate`` on): a walk can stop at
        a local maximum on the far border when its vertex's reflection has moved far since the
        previous frame. Not with ``inverse="search"``, whose hidden vertices' scores are another
        score's (the preset's value is then off; True is refused).
    cap : int, optional
        Iteration cap per search (default ``2 * (width + height)`` of the G-buffer).
    cull_reflectors, reuse, cull_virtual, crop_virtual : bool
        Exact skips (on by default; outputs are bit-identical with them off): no G-buffer and
        no search for a reflector outside the G-buffer's frustum; G-buffer and search results
        reused when the reflector, the camera and the vertex's object did not move; objects
        whose virtual vertices all lie beyond one side of the stencil's box not rasterized; the
        virtual raster restricted to that box.
    adaptive_widen : bool
        An approximation (off by default, changes results): use ``widen`` only on frames where
        the reflector's projection is clipped by the view.
    tessellate : float, optional
        Szabo's adaptive tessellation of the reflected geometry
        (:mod:`refsoft.search.tessellate`): split triangles whose largest edge error exceeds
        this threshold (0: every triangle with an edge measured: every one with
        ``tessellate_span=0``), crack-free, up to ``max_level`` levels. Default off.
    max_level : int
        Tessellation levels at most (paper 3, accurate 1).
    tessellate_span : int
        Edges whose ends reflect at most this many pixels apart (along both axes) are not split
        (beyond the thesis; paper 0: every edge measured, accurate 8: the exact drawing's dilation
        covers a shorter edge's curve).
    refine : bool
        Sub-texel reflection points (:mod:`refsoft.search.refine`, beyond the papers; off by
        default): one Gauss-Newton step from the texel found before mirroring the vertex.
    virtual : {"mirror", "unfold"}
        Virtual vertices of visible reflections: mirrored across the reflection point's tangent
        plane (the papers), or placed on the eye's ray through the reflection point at the
        reflected path's length (beyond the papers: robust to the texel's normal error).
    silhouette : {"texel", "clip"}
        Triangles with visible and hidden vertices: handled by ``inverse`` (the papers), or cut
        where their reflection reaches the reflector's silhouette and their visible part drawn
        (:mod:`refsoft.search.silhouette`, beyond the papers).
    images : {"all", "one"}
        Every reflection point of every vertex (spec section 4.8, :func:`refsoft.search.images.find_images`:
        flag SEVERAL and the per-image arrays, on reflectors that can give two points:
        :func:`refsoft.search.convex.several_possible`), or the walk's one (the papers; ``paper``).
    draw : {"raster", "exact", "edges"}
        How the virtual triangles are drawn in the stencil: rasterized with a z-buffer (the papers;
        ``paper``), or used as candidates of exact per-pixel acceptance, each stencil pixel's
        reflected ray met with the real triangles whose dilated virtual triangles cover it
        (:mod:`refsoft.search.exact`, beyond the papers; ``accurate``), or rasterized and then
        drawn exactly near the outlines of the rasterized reflection and of the mirror
        (``edges``: :func:`refsoft.search.exact.edges_pass`).
    ldt_resolution, ldt_layers, ldt_faces, ldt_linear, ldt_tau, ldt_regions : optional
        ``method="ldt"`` only (default :data:`LDT_DEFAULTS`): texels per cube face edge (4 ..
        4096, a power of two keeps mirrored texels bit-exact); layers built ("all" or 1, the
        convex assumption); faces searched per object ("three" or "entry"); linear steps per
        face (a count or "texel"); the residual in texels a face's hit is accepted under; the
        cone test per reflector triangle ("cone") or none (:class:`refsoft.ldt.LayeredDepthTextures`).
    envmap_resolution : int, optional
        ``method="envmap"`` only (default 256): texels per cube face edge
        (:class:`refsoft.envmap.EnvironmentMap`).
    bounces : int
        Reflections followed per eye ray, 1 to 8 (default 1, the papers): with more, the
        reflectors seen in a reflection are searched and drawn level by level
        (:mod:`refsoft.search.bounces`, spec section 5.1). The vertex search only.
    """

    preset: str = "accurate"
    method: str = FROM_PRESET
    neighbourhood: str = FROM_PRESET
    inverse: str = FROM_PRESET
    widen: float = 1.0
    gbuffer_size: tuple | None = None
    precision: str = "float32"
    coherence: bool = True
    cap: int | None = None
    cull_reflectors: bool = True
    reuse: bool = True
    cull_virtual: bool = True
    crop_virtual: bool = True
    adaptive_widen: bool = False
    tessellate: float | None = FROM_PRESET
    max_level: int = FROM_PRESET
    tessellate_span: int = FROM_PRESET
    refine: bool = FROM_PRESET
    virtual: str = FROM_PRESET
    silhouette: str = FROM_PRESET
    images: str = FROM_PRESET
    draw: str = FROM_PRESET
    border_restart: bool = FROM_PRESET
    ldt_resolution: int | None = None
    ldt_layers: object = None
    ldt_faces: str | None = None
    ldt_linear: object = None
    ldt_tau: float | None = None
    ldt_regions: str | None = None
    envmap_resolution: int | None = None
    bounces: int = 1

    def __post_init__(self):
        validate.choice(self.preset, PRESET_NAMES, "preset")
        if self.border_restart is FROM_PRESET and self.inverse == "search":
            object.__setattr__(self, "border_restart", False)  # the preset's restart needs the walk's own scores
        for name, value in PRESETS[self.preset].items():
            if getattr(self, name) is FROM_PRESET:
                object.__setattr__(self, name, value)
        if self.neighbourhood == "hierarchy":
            raise RefsoftError("neighbourhood must be one of ['cross', 'box']; the hierarchy search is "
                               "method='hierarchy'")
        validate.choice(self.method, METHODS, "method")
        validate.choice(self.neighbourhood, tuple(NEIGHBOURHOODS), "neighbourhood")
        validate.choice(self.inverse, INVERSE_MODES, "inverse")
        validate.choice(self.precision, PRECISIONS, "precision")
        validate.choice(self.virtual, VIRTUAL_RULES, "virtual")
        validate.choice(self.silhouette, SILHOUETTE_RULES, "silhouette")
        validate.choice(self.images, constants.IMAGE_MODES, "images")
        validate.choice(self.draw, constants.DRAW_MODES, "draw")
        validate.number(self.widen, "widen", minimum=1.0)
        if self.tessellate is not None:
            validate.number(self.tessellate, "tessellate", minimum=0.0, what="a threshold >= 0 (or None)")
        validate.integer(self.max_level, "max_level", 0, MAX_TESSELLATION_LEVEL)
        validate.integer(self.tessellate_span, "tessellate_span", 0)
        if self.cap is not None:
            validate.integer(self.cap, "cap", 1)
        for name in SKIPS + ("adaptive_widen", "coherence", "refine", "border_restart"):
            validate.flag(getattr(self, name), name)
        if self.border_restart and self.inverse == "search":
            raise RefsoftError("border_restart compares the walks' scores, which inverse='search' replaces for hidden "
                               "vertices: give border_restart=False or another inverse mode")
        validate.integer(self.bounces, "bounces", 1, constants.MAX_BOUNCES)
        if self.bounces > 1 and self.method in METHOD_DEFAULTS:
            raise RefsoftError(f"bounces > 1 needs the vertex search: method {self.method!r} follows one bounce "
                               f"(give method='walk' or 'hierarchy', or bounces=1)")
        self._check_own_options()

    def _check_own_options(self):
        own = METHOD_DEFAULTS.get(self.method, {})
        for name in sorted(_OWN_OPTIONS - set(own)):
            if getattr(self, name) is not None:
                method = name.split("_")[0]
                raise RefsoftError(f"{name} applies to method={method!r} only (method is {self.method!r})")
        for name, value in own.items():
            if getattr(self, name) is None:
                object.__setattr__(self, name, value)
        if self.method == "ldt":
            self._check_ldt()
        elif self.method == "envmap":
            validate.integer(self.envmap_resolution, "envmap_resolution", 1, constants.LDT_MAX_RESOLUTION)

    def _check_ldt(self):
        validate.integer(self.ldt_resolution, "ldt_resolution", constants.LDT_MIN_RESOLUTION,
                         constants.LDT_MAX_RESOLUTION)
        if self.ldt_layers == "1":
            object.__setattr__(self, "ldt_layers", 1)
        if self.ldt_layers not in constants.LDT_LAYER_MODES or isinstance(self.ldt_layers, bool):
            raise RefsoftError(f"ldt_layers must be 'all' or 1, got {self.ldt_layers!r}")
        validate.choice(self.ldt_faces, constants.LDT_FACE_MODES, "ldt_faces")
        if self.ldt_linear != "texel":
            validate.integer(self.ldt_linear, "ldt_linear", 1, 1 << 16)
        validate.number(self.ldt_tau, "ldt_tau", minimum=0.0)
        validate.choice(self.ldt_regions, constants.LDT_REGION_MODES, "ldt_regions")

    def without_skips(self) -> "RenderOptions":
        """The same options with every exact skip off (the reference the skips are tested
        against)."""
        return replace(self, **dict.fromkeys(SKIPS, False))

    @classmethod
    def from_preset(cls, preset: str = "accurate", **options) -> "RenderOptions":
        """``RenderOptions(preset=preset, **options)``."""
        return cls(preset=preset, **options)

    def as_dict(self) -> dict:
        """The options the method reads, by name (tuples as lists), as ``stats.json`` and golden
        manifests record them: for the vertex search the preset and every option but the LDT's
        (``bounces`` only when more than one);
        for ``method="ldt"`` the method, the precision and the LDT's options.
        ``RenderOptions(**as_dict())`` gives these options back."""
        if self.method in METHOD_DEFAULTS:
            names = ("method", "precision") + tuple(METHOD_DEFAULTS[self.method])
        else:
            names = tuple(f.name for f in fields(self) if f.name not in _OWN_OPTIONS
                          and not (f.name == "bounces" and self.bounces == 1))  # one bounce: as before
        return {name: (list(v) if isinstance(v, tuple) else v) for name in names for v in [getattr(self, name)]}
