"""refsoft-glsl: the main method of refsoft (per-vertex reflection-point search, Estalella et al.
2006) and both comparison methods (Zhang, Hsieh and Shen's layered depth textures, the
environment map) ported to GLSL and run headless on Mesa llvmpipe through moderngl's EGL backend.

It reads a golden case's inputs (``CASE/inputs/``) and writes the candidate layout that
``refsoft check`` judges. The exact variant is bit-identical to refsoft; the plain variant
(``--plain``) is written the way ports usually are (docs/ports.md, "A worked example: the GLSL
port").
"""

__version__ = "0.1.0"
