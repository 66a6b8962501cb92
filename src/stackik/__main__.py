"""``python -m stackik``: the command line (see :mod:`stackik.cli`)."""

from stackik.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
