"""``python -m refsoft``: the command line."""

try:
    from ._start import run
except KeyboardInterrupt:  # Ctrl-C while this very import runs (the guard is refsoft's __init__'s handler)
    import sys

    from .interrupt import MESSAGE

    print(MESSAGE, file=sys.stderr)
    sys.exit(130)

run()
