"""The bad-input corpus (spec section 10): each case is a scene file (and mesh files)
or a command line that must be refused with one line naming the problem.

A case: ``(id, files, argv, error, message)``. ``files`` maps names to text (written into a
fresh folder); ``argv`` is the ``refsoft`` command line with ``{d}`` for that folder;
``error`` is the exception type the Python API raises for the same input (through
:func:`api_call`), ``message`` a fragment both the exception and the CLI line contain.
"""

from refsoft.errors import CameraError, LimitError, MeshError, RefsoftError, SceneError

CAMERA = """[camera]
eye = [0.0, 1.0, 5.0]
target = [0.0, 0.0, 0.0]
width = 64
height = 48
"""
BALL = """[[objects]]
name = "ball"
primitive = { type = "icosphere", subdivisions = 2 }
reflector = true
"""
FLOOR = """[[objects]]
name = "floor"
primitive = { type = "plane", size = [6.0, 6.0], divisions = [4, 4] }
translate = [0.0, -1.0, 0.0]
"""
TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def scene(camera=CAMERA, objects=BALL + FLOOR, extra=""):
    return camera + objects + extra


def with_camera(**kv):
    """The camera table with keys replaced (value None drops the key)."""
    lines = [ln for ln in CAMERA.splitlines()[1:] if ln.split(" = ")[0] not in kv]
    lines += [f"{k} = {v}" for k, v in kv.items() if v is not None]
    return "[camera]\n" + "\n".join(lines) + "\n"


def obj(name="thing", **kv):
    """One [[objects]] entry with the given keys (TOML values as text)."""
    return "[[objects]]\n" + f'name = "{name}"\n' + "".join(f"{k} = {v}\n" for k, v in kv.items())


PRIM = '{ type = "box" }'
RENDER = ["render", "{d}/scene.toml", "--out", "{d}/out", "--frames", "1"]
ANIM = """[animation]
frames = 4
[[animation.camera]]
frame = 0
eye = [0.0, 1.0, 5.0]
"""

CASES = [
    # --- the scene file itself
    ("malformed_toml", {"scene.toml": "[camera\neye = [0, 1, 5]\n"}, RENDER, SceneError, "malformed TOML"),
    ("not_utf8", {"scene.toml": b"\xff\xfe[camera]\n"}, RENDER, SceneError, "scene.toml"),
    ("unknown_top_key", {"scene.toml": "colour = 1\n" + scene()}, RENDER, SceneError, "colour: unknown key"),
    ("unknown_camera_key", {"scene.toml": scene(with_camera(fovy=40))}, RENDER, SceneError, "camera.fovy: unknown key"),
    ("unknown_object_key", {"scene.toml": scene(objects=BALL + FLOOR.replace('name = "floor"', 'name = "floor"\ncolr = [1, 0, 0]'))},
     RENDER, SceneError, "objects[1].colr: unknown key"),
    ("missing_camera", {"scene.toml": BALL + FLOOR}, RENDER, SceneError, "missing table [camera]"),
    ("missing_eye", {"scene.toml": scene(with_camera(eye=None))}, RENDER, SceneError, "camera.eye: missing key"),
    ("eye_is_not_a_vector", {"scene.toml": scene(with_camera(eye="[0.0, 1.0]"))}, RENDER, SceneError,
     "camera.eye: must be a list of 3 numbers"),
    ("eye_has_nan", {"scene.toml": scene(with_camera(eye="[nan, 1.0, 5.0]"))}, RENDER, SceneError,
     "camera.eye[0]: must be a finite number"),
    ("eye_equals_target", {"scene.toml": scene(with_camera(eye="[0.0, 0.0, 0.0]"))}, RENDER, SceneError,
     "eye equals target"),
    ("up_parallel_to_view", {"scene.toml": scene(with_camera(eye="[0.0, 5.0, 0.0]"))}, RENDER, SceneError,
     "parallel to the view direction"),
    ("up_zero", {"scene.toml": scene(with_camera(up="[0.0, 0.0, 0.0]"))}, RENDER, SceneError, "up is the zero vector"),
    ("fov_zero", {"scene.toml": scene(with_camera(fov_y=0.0))}, RENDER, SceneError, "fov_y must be in (0, 180)"),
    ("fov_180", {"scene.toml": scene(with_camera(fov_y=180.0))}, RENDER, SceneError, "fov_y must be in (0, 180)"),
    ("near_after_far", {"scene.toml": scene(with_camera(near=10.0, far=1.0))}, RENDER, SceneError, "0 < near < far"),
    ("near_zero", {"scene.toml": scene(with_camera(near=0.0))}, RENDER, SceneError, "0 < near < far"),
    ("width_zero", {"scene.toml": scene(with_camera(width=0))}, RENDER, SceneError, "width must be positive"),
    ("height_negative", {"scene.toml": scene(with_camera(height=-5))}, RENDER, SceneError, "height must be positive"),
    ("width_a_string", {"scene.toml": scene(with_camera(width='"640"'))}, RENDER, SceneError,
     "camera.width: must be an integer"),
    ("width_absurd", {"scene.toml": scene(with_camera(width=10 ** 6))}, RENDER, SceneError, "exceeds the limit"),
    ("unknown_projection", {"scene.toml": scene(with_camera(projection='"fisheye"'))}, RENDER, SceneError,
     "projection must be 'perspective' or 'orthographic'"),
    ("ortho_height_zero", {"scene.toml": scene(with_camera(projection='"orthographic"', ortho_height=0.0))}, RENDER,
     SceneError, "ortho_height must be positive"),
    # --- objects
    ("no_objects", {"scene.toml": CAMERA}, RENDER, SceneError, "needs at least one [[objects]] entry"),
    ("mesh_and_primitive", {"scene.toml": scene(objects=BALL + obj(mesh='"t.obj"', primitive=PRIM))}, RENDER, SceneError,
     "needs exactly one of 'mesh' or 'primitive'"),
    ("neither_mesh_nor_primitive", {"scene.toml": scene(objects=BALL + obj(color="[1.0, 0.0, 0.0]"))}, RENDER,
     SceneError, "needs exactly one of 'mesh' or 'primitive'"),
    ("duplicate_names", {"scene.toml": scene(objects=BALL + obj("ball", primitive=PRIM))}, RENDER, SceneError,
     "duplicate object name 'ball'"),
    ("empty_name", {"scene.toml": scene(objects=BALL + obj("", primitive=PRIM))}, RENDER, SceneError,
     "must be a non-empty string"),
    ("unknown_primitive", {"scene.toml": scene(objects=BALL + obj(primitive='{ type = "teapot" }'))}, RENDER,
     SceneError, "teapot"),
    ("bad_primitive_parameter", {"scene.toml": scene(objects=BALL + obj(primitive='{ type = "icosphere", subdivisions = -1 }'))},
     RENDER, SceneError, "subdivisions"),
    ("negative_scale", {"scene.toml": scene(objects=BALL + obj(primitive=PRIM, scale=-1.0))}, RENDER, SceneError,
     "objects[1].scale: must be positive"),
    ("zero_scale", {"scene.toml": scene(objects=BALL + obj(primitive=PRIM, scale="[1.0, 0.0, 1.0]"))}, RENDER,
     SceneError, "objects[1].scale: must be positive"),
    ("translate_inf", {"scene.toml": scene(objects=BALL + obj(primitive=PRIM, translate="[inf, 0.0, 0.0]"))}, RENDER,
     SceneError, "objects[1].translate[0]: must be a finite number"),
    ("color_out_of_range", {"scene.toml": scene(objects=BALL + obj(primitive=PRIM, color="[2.0, 0.0, 0.0]"))}, RENDER,
     SceneError, "color must be 3 numbers in [0, 1]"),
    ("color_two_numbers", {"scene.toml": scene(objects=BALL + obj(primitive=PRIM, color="[1.0, 0.0]"))}, RENDER,
     SceneError, "objects[1].color: must be a list of 3 numbers"),
    ("reflector_not_bool", {"scene.toml": scene(objects=obj("ball", primitive='{ type = "icosphere" }', reflector='"yes"'))},
     RENDER, SceneError, "objects[0].reflector: must be true or false"),
    ("reflectivity_above_one", {"scene.toml": scene(objects=BALL.replace("reflector = true", "reflector = true\nreflectivity = 1.5") + FLOOR)},
     RENDER, SceneError, "reflectivity must be in [0, 1]"),
    ("open_reflector_without_proxy", {"scene.toml": scene(objects=obj("mirror", primitive='{ type = "plane" }', reflector="true") + BALL.replace("reflector = true", ""))},
     RENDER, SceneError, "open mesh"),
    ("open_closed_proxy", {"scene.toml": scene(objects=BALL.replace("reflector = true", 'reflector = true\nclosed_proxy = { type = "plane" }') + FLOOR)},
     RENDER, SceneError, "closed_proxy is not closed"),
    ("proxy_on_non_reflector", {"scene.toml": scene(objects=BALL + obj(primitive=PRIM, closed_proxy=PRIM))}, RENDER,
     SceneError, "not a reflector"),
    ("no_reflector", {"scene.toml": scene(objects=FLOOR)}, RENDER, RefsoftError, "has no reflector"),
    # --- mesh files
    ("mesh_file_missing", {"scene.toml": scene(objects=BALL + obj(mesh='"missing.obj"'))}, RENDER, SceneError,
     "mesh file not found"),
    ("mesh_path_is_a_folder", {"scene.toml": scene(objects=BALL + obj(mesh='"sub"')), "sub/x.txt": "x"}, RENDER,
     SceneError, "mesh file not found"),
    ("mesh_file_garbage", {"scene.toml": scene(objects=BALL + obj(mesh='"g.ply"')), "g.ply": "ply\nformat nonsense\n"},
     RENDER, SceneError, "cannot read mesh"),
    ("mesh_empty", {"scene.toml": scene(objects=BALL + obj(mesh='"e.obj"')), "e.obj": "# nothing\n"}, RENDER,
     SceneError, "holds no triangle mesh"),
    ("mesh_without_faces", {"scene.toml": scene(objects=BALL + obj(mesh='"p.obj"')), "p.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\n"},
     RENDER, SceneError, "holds no triangle mesh"),
    ("mesh_nan_vertex", {"scene.toml": scene(objects=BALL + obj(mesh='"n.obj"')), "n.obj": TRI.replace("v 0 0 0", "v nan 0 0")},
     RENDER, SceneError, "non-finite vertices"),
    ("mesh_inf_vertex", {"scene.toml": scene(objects=BALL + obj(mesh='"i.obj"')), "i.obj": TRI.replace("v 1 0 0", "v 1 inf 0")},
     RENDER, SceneError, "non-finite vertices"),
    ("mesh_face_out_of_range", {"scene.toml": scene(objects=BALL + obj(mesh='"o.obj"')), "o.obj": TRI.replace("f 1 2 3", "f 1 2 9")},
     RENDER, SceneError, "out of bounds"),
    # --- animation
    ("animation_without_frames", {"scene.toml": scene(extra="[animation]\n")}, RENDER, SceneError,
     "animation.frames: missing key"),
    ("animation_zero_frames", {"scene.toml": scene(extra=ANIM.replace("frames = 4", "frames = 0"))}, RENDER, SceneError,
     "frames must be a positive integer"),
    ("animation_key_after_the_end", {"scene.toml": scene(extra=ANIM + "[[animation.camera]]\nframe = 9\neye = [1.0, 1.0, 5.0]\n")},
     RENDER, SceneError, "key frames must be in [0, 3]"),
    ("animation_keys_not_increasing", {"scene.toml": scene(extra=ANIM + "[[animation.camera]]\nframe = 0\neye = [1.0, 1.0, 5.0]\n")},
     RENDER, SceneError, "strictly increasing"),
    ("animation_key_without_frame", {"scene.toml": scene(extra=ANIM + "[[animation.camera]]\neye = [1.0, 1.0, 5.0]\n")},
     RENDER, SceneError, "animation.camera[1].frame: missing key"),
    ("animation_unknown_object", {"scene.toml": scene(extra=ANIM + '[[animation.objects]]\nname = "ghost"\nframe = 2\n')},
     RENDER, SceneError, "no object named 'ghost'"),
    ("animation_camera_degenerate", {"scene.toml": scene(extra=ANIM + "[[animation.camera]]\nframe = 3\neye = [0.0, 0.0, 0.0]\n")},
     RENDER, SceneError, "eye equals target"),
    # --- the command line
    ("scene_file_missing", {}, RENDER, SceneError, "scene file not found"),
    ("unknown_builtin", {}, ["render", "nosuchscene", "--out", "{d}/out"], RefsoftError, "unknown scene 'nosuchscene'"),
    ("cli_width_zero", {"scene.toml": scene()}, RENDER + ["--width", "0"], CameraError, "width must be positive"),
    ("cli_frames_zero", {"scene.toml": scene()}, RENDER[:-2] + ["--frames", "0"], RefsoftError, "frames must be positive"),
    ("cli_frame_out_of_range", {"scene.toml": scene(extra=ANIM)}, RENDER[:-2] + ["--frame", "7"], RefsoftError,
     "7"),
    ("cli_too_many_frames", {"scene.toml": scene(extra=ANIM)}, RENDER[:-2] + ["--frames", "9"], RefsoftError,
     "has 4 frames, asked for 9"),
    ("cli_widen_below_one", {"scene.toml": scene()}, RENDER + ["--widen", "0.5"], RefsoftError, "widen must be a number >= 1"),
    ("cli_memory_limit_tiny", {"scene.toml": scene()}, RENDER + ["--memory-limit", "10k"], LimitError, "needs about"),
    ("cli_memory_limit_malformed", {"scene.toml": scene()}, RENDER + ["--memory-limit", "lots"], RefsoftError,
     "memory limit must be a size"),
]


def api_call(case_dir, argv):
    """The Python API's equivalent of a case's ``render`` command line."""
    import refsoft

    args = dict(zip(argv[2::2], argv[3::2]))
    target = argv[1].format(d=case_dir)
    kw = {}
    if "--width" in args:
        kw["width"] = int(args["--width"])
    scene = refsoft.load_scene(target, **kw)
    options = {}
    if "--widen" in args:
        options["widen"] = float(args["--widen"])
    frames = int(args["--frames"]) if "--frames" in args else None
    if "--frame" in args:
        frames = [int(args["--frame"])]
    return refsoft.render(scene, frames=frames, memory_limit=args.get("--memory-limit"), **options)
