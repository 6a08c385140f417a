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
