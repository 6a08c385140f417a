"""``python -m refsoft``: the command line."""

try:
    from ._start import run
except KeyboardInterrupt:  # Ctrl-C while this very import runs (the guard is refsoft's __init__'s handler)
    import sys

    print("refsoft: interrupted", file=sys.stderr)
    sys.exit(130)

run()
