"""Truth and error (spec section 6): the ray-traced truth (:mod:`.raytrace`), exact reflection
points on spheres (:mod:`.analytic`) and the metrics of a render against its truth
(:mod:`.metrics`)."""

from .raytrace import RayTracedTruth, TruthRenderer, exact_sphere_vertices, render_truth

__all__ = ["RayTracedTruth", "TruthRenderer", "exact_sphere_vertices", "render_truth"]
