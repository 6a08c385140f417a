"""Option groups shared by the subcommands (argparse ``parents=``), their choices taken from the
library's own tuples, and their translation into library arguments."""

from __future__ import annotations

import argparse
import sys

from .. import constants
from ..errors import RefsoftError


def _parser():
    return argparse.ArgumentParser(add_help=False)


def scene_options() -> argparse.ArgumentParser:
    """The scene and the image size."""
    p = _parser()
    p.add_argument("scene", help="built-in scene name (refsoft scenes lists them) or a TOML scene file")
    p.add_argument("--width", type=int, default=None, help="image width in pixels (default: the scene's)")
    p.add_argument("--height", type=int, default=None, help="image height in pixels (default: the scene's)")
    p.add_argument("--subdivide", type=float, default=None, metavar="L",
                   help="loader subdivision: split the non-reflector triangles with an edge longer than L world "
                        "units (overrides the scene's own values; 0 = off; docs/scenes.md)")
    return p


def frame_range_options() -> argparse.ArgumentParser:
    """Which frames a render or a truth covers."""
    p = _parser()
    p.add_argument("--frames", type=int, default=None, metavar="N",
                   help="frames 0..N-1 (default: the whole animation; 1 for a static scene)")
    p.add_argument("--frame", type=int, default=None, metavar="K",
                   help="only frame K (a render runs frames 0..K for coherence and writes K)")
    return p


def one_frame_options() -> argparse.ArgumentParser:
    """One frame of the scene."""
    p = _parser()
    p.add_argument("--frame", type=int, default=0, metavar="K", help="the frame (default 0)")
    return p


def method_options() -> argparse.ArgumentParser:
    """The preset, the reflection method and the search's options (each overrides the preset)."""
    p = _parser()
    p.add_argument("--preset", choices=constants.PRESET_NAMES, default="accurate",
                   help="a named set of the options below: 'accurate' (the default: chosen against the ray-traced "
                        "truth, docs/accuracy.md) or 'paper' (the papers' method verbatim); options given one by "
                        "one override it")
    p.add_argument("--method", choices=constants.METHODS, default=None,
                   help="the reflection method: the vertex search's linear walk from a start pixel (the papers; "
                        "both presets) or Szabo's ray-cone hierarchy, or Zhang, Hsieh and Shen's layered depth "
                        "textures searched per pixel (ldt, the --ldt-* options), or the environment-map baseline "
                        "(envmap: a cube map per reflector looked up by direction alone)")
    p.add_argument("--neighbourhood", choices=tuple(constants.NEIGHBOURHOODS), default=None,
                   help="the walk's candidates per step: the crosshair or the 3x3 box (paper: cross, accurate: box)")
    p.add_argument("--search", choices=("cross", "box", "hierarchy"), default=None, help=argparse.SUPPRESS)
    p.add_argument("--inverse", choices=constants.INVERSE_MODES, default=None,
                   help="hidden vertices: Estalella's plane rule, an inverse search, or their triangles "
                        "discarded (paper: plane, accurate: discard)")
    p.add_argument("--widen", type=float, default=None, metavar="FACTOR",
                   help="wider field of view of the G-buffers, for reflectors cut by the image border "
                        "(Estalella 5.2; default 1 = off)")
    p.add_argument("--precision", choices=constants.PRECISIONS, default=None,
                   help="G-buffer and search arithmetic (default float32, as a GPU)")
    p.add_argument("--no-coherence", action="store_true",
                   help="start every search at the default start, not at the last frame's pixel")
    return p


def render_options() -> argparse.ArgumentParser:
    """What only a render takes: tessellation, refinement, virtual vertices, silhouette, skips
    (each overrides the preset)."""
    p = _parser()
    p.add_argument("--tessellate", type=_threshold, default=None, metavar="THRESHOLD",
                   help="Szabo's adaptive tessellation of reflected triangles whose edge error exceeds THRESHOLD "
                        "(e.g. 1e-3; 0 = full tessellation; 'off' = none), crack-free (paper: off, accurate: 1e-3)")
    p.add_argument("--max-level", type=int, default=None, metavar="L",
                   help="tessellation levels at most (paper: 3, accurate: 1)")
    p.add_argument("--tessellate-span", type=int, default=None, metavar="PX",
                   help="beyond the thesis: edges whose ends reflect at most PX pixels apart are not split "
                        "(paper: 0, accurate: 1)")
    p.add_argument("--refine", action=argparse.BooleanOptionalAction, default=None,
                   help="beyond the papers: sub-texel reflection points (one Gauss-Newton step from the texel "
                        "found) (paper: off, accurate: on)")
    p.add_argument("--virtual", choices=constants.VIRTUAL_RULES, default=None,
                   help="virtual vertices: mirrored across the reflection point's tangent plane (the papers), or "
                        "unfolded onto the eye's ray through it (beyond the papers) (paper: mirror, accurate: unfold)")
    p.add_argument("--silhouette", choices=constants.SILHOUETTE_RULES, default=None,
                   help="triangles with visible and hidden vertices: left to --inverse (the papers), or cut where "
                        "their reflection reaches the silhouette (paper: texel, accurate: clip)")
    p.add_argument("--images", choices=constants.IMAGE_MODES, default=None,
                   help="beyond the papers: every reflection point of every vertex on mirrors that are not convex "
                        "(flag SEVERAL, per-image arrays), or the walk's one (paper: one, accurate: all)")
    p.add_argument("--border-restart", action=argparse.BooleanOptionalAction, default=None,
                   help="beyond the papers: a coherent walk that stops on the G-buffer's border is walked again "
                        "from the start without history, the higher score kept (paper: off, accurate: on)")
    p.add_argument("--draw", choices=constants.DRAW_MODES, default=None,
                   help="the virtual triangles rasterized with a z-buffer (the papers), or beyond them: each mirror "
                        "pixel's reflected ray met exactly with the real triangles whose virtual triangles cover it "
                        "(exact), or rasterized and met exactly within 2 pixels of an outline (edges) (paper: raster, "
                        "accurate: exact)")
    p.add_argument("--bounces", default=None, metavar="N",
                   help="beyond the papers: reflections followed per eye ray, 1 to 8 (default 1): mirrors that see "
                        "each other, searched and drawn level by level (the vertex search only)")
    p.add_argument("--adaptive-widen", action="store_true",
                   help="approximation: use --widen only on frames where a reflector is cut by the image border")
    p.add_argument("--no-skip", action="append", metavar="NAME",
                   choices=[s.replace("_", "-") for s in constants.SKIPS],
                   help="turn one exact skip off (repeatable): " + ", ".join(s.replace("_", "-") for s in constants.SKIPS)
                        + "; outputs are identical either way, only the time changes")
    p.add_argument("--no-skips", action="store_true", help="turn every exact skip off")
    return p


def ldt_options() -> argparse.ArgumentParser:
    """The per-pixel methods' options: the layered depth textures' (``--method ldt`` only) and
    the environment map's (``--method envmap`` only)."""
    p = _parser()
    p.add_argument("--ldt-resolution", type=int, default=None, metavar="R",
                   help=f"ldt: texels per cube face edge (default {constants.LDT_RESOLUTION}; a power of two)")
    p.add_argument("--ldt-layers", choices=("all", "1"), default=None,
                   help="ldt: depth layers built: all (up to 8) or 1, the convex assumption (default all)")
    p.add_argument("--ldt-faces", choices=constants.LDT_FACE_MODES, default=None,
                   help="ldt: faces searched per object: up to three, or the entry face only (default three)")
    p.add_argument("--ldt-linear", default=None, metavar="N",
                   help=f"ldt: linear search steps per face, or 'texel' (one per texel; default "
                        f"{constants.LDT_LINEAR_STEPS})")
    p.add_argument("--ldt-tau", type=float, default=None, metavar="TEXELS",
                   help=f"ldt: residual under which a face's hit is accepted (default {constants.LDT_TAU:g})")
    p.add_argument("--ldt-regions", choices=constants.LDT_REGION_MODES, default=None,
                   help="ldt: the cone test per reflector triangle, or none (default cone)")
    p.add_argument("--envmap-resolution", type=int, default=None, metavar="R",
                   help=f"envmap: texels per cube face edge (default {constants.ENVMAP_RESOLUTION})")
    return p


def ldt_kwargs(args) -> dict:
    """The ``--ldt-*`` options given, as :class:`refsoft.RenderOptions` fields."""
    out = {}
    for name in ("resolution", "layers", "faces", "linear", "tau", "regions"):
        value = getattr(args, "ldt_" + name, None)
        if value is None:
            continue
        if name == "layers" and value == "1":
            value = 1
        if name == "linear" and value != "texel":
            try:
                value = int(value)
            except ValueError:
                raise RefsoftError(f"--ldt-linear must be a step count or 'texel', got {value!r}") from None
        out["ldt_" + name] = value
    if getattr(args, "envmap_resolution", None) is not None:
        out["envmap_resolution"] = args.envmap_resolution
    return out


#: The render options that only the vertex search reads (refused with ``--method ldt``).
_VERTEX_SEARCH_FLAGS = ("neighbourhood", "inverse", "widen", "tessellate", "max_level", "tessellate_span", "refine",
                        "virtual", "silhouette", "images", "draw", "border_restart", "bounces")


def _count(text, flag):
    """An integer option read here rather than by argparse, so that a bad value is one line."""
    try:
        return int(text)
    except ValueError:
        raise RefsoftError(f"{flag} must be an integer, got {text!r}") from None


def _threshold(text):
    """--tessellate's value: a number, or 'off'/'none' for no tessellation."""
    if text.lower() in ("off", "none"):
        return "off"
    return float(text)


def memory_options() -> argparse.ArgumentParser:
    p = _parser()
    p.add_argument("--memory-limit", default=None, metavar="SIZE",
                   help="refuse a run estimated to need more memory (e.g. 4G; default $REFSOFT_MEMORY_LIMIT or 4G)")
    return p


def out_option(default: str) -> argparse.ArgumentParser:
    p = _parser()
    p.add_argument("--out", default=default, metavar="DIR", help=f"output folder (default: {default})")
    return p


def run_folder_options(default: str) -> argparse.ArgumentParser:
    """The folder a run owns, and leave to replace an earlier run's files there."""
    p = _parser()
    p.add_argument("--out", default=None, metavar="DIR", help=f"output folder (default: {default})")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the files of an earlier run in the output folder (refused without it)")
    return p


def search_kwargs(args) -> dict:
    """The preset and the search options of :func:`method_options` that were given, as
    :class:`refsoft.RenderOptions` fields (the hidden ``--search`` spelling mapped onto them)."""
    out = {"preset": args.preset}
    method, neighbourhood = args.method, args.neighbourhood
    if args.search is not None:
        print("refsoft: note: --search is now --method walk|hierarchy with --neighbourhood cross|box",
              file=sys.stderr)
        method, neighbourhood = ("hierarchy", neighbourhood) if args.search == "hierarchy" else ("walk", args.search)
    given = dict(method=method, neighbourhood=neighbourhood, inverse=args.inverse, widen=args.widen,
                 precision=args.precision)
    out.update({k: v for k, v in given.items() if v is not None})
    if args.no_coherence:
        out["coherence"] = False
    return out


def render_kwargs(args) -> dict:
    """The preset and every :class:`refsoft.RenderOptions` field a ``refsoft render`` command
    line gives."""
    out = search_kwargs(args)
    given = dict(max_level=args.max_level, tessellate_span=args.tessellate_span, refine=args.refine,
                 virtual=args.virtual, silhouette=args.silhouette, images=args.images, draw=args.draw,
                 border_restart=args.border_restart,
                 bounces=None if args.bounces is None else _count(args.bounces, "--bounces"))
    out.update({k: v for k, v in given.items() if v is not None})
    if args.tessellate is not None:
        out["tessellate"] = None if args.tessellate == "off" else args.tessellate
    if args.adaptive_widen:
        out["adaptive_widen"] = True
    off = set(constants.SKIPS) if args.no_skips else {n.replace("-", "_") for n in args.no_skip or ()}
    out.update({name: False for name in off})
    out.update(ldt_kwargs(args))
    method = out.get("method")
    if method in ("ldt", "envmap"):
        vertex_only = [k for k in _VERTEX_SEARCH_FLAGS if getattr(args, k, None) is not None]
        vertex_only += ["no_coherence"] * bool(args.no_coherence) + ["adaptive_widen"] * bool(args.adaptive_widen)
        vertex_only += ["no_skip"] * bool(args.no_skips or args.no_skip)
        if vertex_only:
            raise RefsoftError(f"--{vertex_only[0].replace('_', '-')} is an option of the vertex search; --method "
                               f"{method} takes the --{method}-* options and --precision")
        out = {k: v for k, v in out.items() if k in ("method", "precision") or k.startswith(("ldt_", "envmap_"))}
    return out
