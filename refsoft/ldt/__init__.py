"""Layered depth textures (Zhang, Hsieh and Shen 2008), a comparison method beside the vertex search
(docs/ldt.md).

- :mod:`refsoft.ldt.build`: one object's LDT (:class:`LDT`, :func:`build_ldt`), once, in model
  space;
- :mod:`refsoft.ldt.regions`: the paper's cone test per reflector triangle and object;
- :mod:`refsoft.ldt.search`: the per-pixel search (:func:`search`, Numba kernel in
  :mod:`refsoft.ldt._search`);
- :mod:`refsoft.ldt.method`: :class:`LayeredDepthTextures`, the method behind the seam
  (:mod:`refsoft.seam`);
- :mod:`refsoft.ldt.trace`: the replay of one pixel's search, step by step (:func:`trace_pixel`);
- :mod:`refsoft.ldt.constants`: defaults, caps, the face table and the flag bits.
"""

from .build import LDT, build_ldt
from .method import LayeredDepthTextures
from .regions import cone_test
from .search import Stack, search
from .trace import PixelTrace, trace_pixel, write_pixel_trace

__all__ = ["LDT", "build_ldt", "LayeredDepthTextures", "cone_test", "Stack", "search", "PixelTrace", "trace_pixel",
           "write_pixel_trace"]
