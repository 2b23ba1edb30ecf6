"""``python -m astrocpg.studies.cli``: the ``astrocpg`` command."""

from . import entry

entry()
