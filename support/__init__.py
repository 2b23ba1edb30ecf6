"""What every floor of the package leans on and none of them owns: reading user files within
bounds (:mod:`.reading`), the environment's switches (:mod:`.environment`), the shipped files
found by name (:mod:`.shipped`), standard streams that survive being closed (:mod:`._streams`)
and Brian2 imported quietly (:mod:`._quiet_brian`). Each imports nothing of the model, the
network, the coupling or the studies. The package's public exceptions stay at
:mod:`astrocpg.errors`; ``_versioning.py`` stays beside ``__init__.py``, where the build
backend loads it by path."""
