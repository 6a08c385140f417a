"""The frame driver and the output contract (spec sections 1, 5 and 7): the main view, one
reflection method per reflector, the composite, and the ``frame_NNNN.npz`` / ``stats.json``
outputs, frame after frame."""

from .driver import Frame, FrameDriver, frame_indices, render, resolve_scene, run_frames
from ..constants import METHODS, SKIPS
from ..options import RenderOptions
from .outputs import frame_stats, write_frame

__all__ = ["Frame", "FrameDriver", "RenderOptions", "render", "frame_indices", "frame_stats", "run_frames",
           "write_frame", "resolve_scene", "METHODS", "SKIPS"]
