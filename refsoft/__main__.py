"""``python -m refsoft``: the command line."""

from ._start import run

run()
