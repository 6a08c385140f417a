"""The environment-map baseline (docs/envmap.md): per reflector and frame a cube map of the
reflected objects around the reflector's centre, looked up by the reflected direction alone.

- :mod:`refsoft.envmap.cube`: GL's face table, the face projections, the build
  (:func:`build_cube_map`) and the nearest-texel lookup (:func:`lookup`);
- :mod:`refsoft.envmap.method`: the reflected rays at the stencil pixels
  (:func:`reflected_rays`) and :class:`EnvironmentMap`, the reflection method
  (:mod:`refsoft.seam`).
"""

from .cube import FACE_NAMES, CubeMap, build_cube_map, face_clip, face_coordinates, lookup, select_face
from .method import (ENVMAP_CENTER, ENVMAP_COLOR, ENVMAP_FACE, ENVMAP_ID, ENVMAP_TEXEL, EnvironmentMap, EnvmapState,
                     Rays, reflected_rays)

__all__ = ["FACE_NAMES", "CubeMap", "build_cube_map", "face_clip", "face_coordinates", "lookup", "select_face",
           "ENVMAP_CENTER", "ENVMAP_COLOR", "ENVMAP_FACE", "ENVMAP_ID", "ENVMAP_TEXEL", "EnvironmentMap",
           "EnvmapState", "Rays", "reflected_rays"]
