"""Exception types raised at refsoft's public boundary.

All derive from :class:`RefsoftError` (itself a :class:`ValueError`), so callers can catch one
type; the CLI turns each into a one-line message and a non-zero exit.
"""


class RefsoftError(ValueError):
    """Base class of every error refsoft raises on bad input."""


class SceneError(RefsoftError):
    """A scene file or scene description is malformed (the message names file and key)."""


class MeshError(RefsoftError):
    """A mesh is empty, has non-finite vertices, bad faces or mismatched arrays."""


class CameraError(RefsoftError):
    """A camera is degenerate: eye equals target, up parallel to the view, bad fov or size."""


class LimitError(RefsoftError):
    """A request would need more memory than the configured limits allow."""


class InputFileError(RefsoftError):
    """A file refsoft reads (a frame's ``.npz``, a traces, manifest or run ``.json``) is missing,
    unreadable or inconsistent with what it should hold (the message names the file)."""
