"""Experiments, each a function with typed settings that returns a result and, given ``out=``,
writes the same folder as the command of the same name: :func:`unit`, :func:`run`,
:func:`train`, :func:`power`."""
