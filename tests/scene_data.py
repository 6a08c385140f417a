"""Scene files shared by the tests."""

# a mirror ball, a box and a floor; the camera moves over 4 frames
ANIMATED = """
[camera]
eye = [0.0, 1.0, 5.0]
target = [0.0, 0.0, 0.0]
width = 160
height = 120
[[objects]]
name = "ball"
primitive = { type = "icosphere", subdivisions = 4 }
reflector = true
[[objects]]
name = "box"
primitive = { type = "box", subdivisions = 3 }
translate = [1.5, 0.0, 1.0]
color = [0.9, 0.2, 0.1]
[[objects]]
name = "floor"
primitive = { type = "plane", size = [8.0, 8.0], divisions = [16, 16] }
translate = [0.0, -1.0, 0.0]
color = [0.2, 0.6, 0.2]
[animation]
frames = 4
[[animation.camera]]
frame = 0
eye = [0.0, 1.0, 5.0]
[[animation.camera]]
frame = 3
eye = [0.8, 1.3, 4.4]
"""


def sphere_searched(inverse, width=160, height=120):
    """The built-in ``sphere`` scene's mirror searched once (cross neighbourhood, ``inverse``):
    ``(scene, gbuffer, vertices, owner, combined non-reflector mesh, SearchResult)``."""
    import refsoft
    from refsoft import raster, search
    from refsoft.scene import scene_vertices
    from refsoft.scene.mesh import concatenate

    scene = refsoft.load_scene("sphere", width=width, height=height)
    cam = scene.camera
    verts, owner = scene_vertices(scene)
    gb = raster.gbuffer(scene.world_mesh(1, proxy=True), cam, origin=cam.eye)
    res = search.search(gb, cam.eye, verts, "cross", inverse)
    ids = [k for k, o in enumerate(scene.objects, start=1) if not o.reflector]
    return scene, gb, verts, owner, concatenate([scene.world_mesh(k) for k in ids], ids), res
