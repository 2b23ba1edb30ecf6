"""``python -m astrocpg``: the ``astrocpg`` command line."""

from .studies.cli import entry

if __name__ == "__main__":
    entry()
