"""The ``refsoft`` command's entry point: imports the command line inside the interrupt guard, so
Ctrl-C at any moment, even while Python loads NumPy and Numba, ends with one line and status 130."""

import sys


def main(argv=None) -> int:
    from . import interrupt

    if not interrupt.installed():
        interrupt.install()
    try:
        from .cli import main as cli_main
    except KeyboardInterrupt:
        print("refsoft: interrupted", file=sys.stderr)
        return 130
    return cli_main(argv, installed=True)


def run() -> None:
    """``sys.exit(main())``, for ``python -m refsoft`` and the console script."""
    import signal

    try:
        code = main()
    except KeyboardInterrupt:  # between the guard's own steps
        code = 130
        print("refsoft: interrupted", file=sys.stderr)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the work is done: an interrupt now changes nothing
    sys.exit(code)
