"""What the commands and the parameter studies run on: the engine that runs many cells (a
study's runs, an evaluation's controller x world cells) here or on a Dask cluster
(``cells``, ``cluster``), the progress bars (``progress``), the memory checks
(``resources``), the worker processes of a command (``workers``) and the caches kept between
processes (``caches``: the folder; ``describe_cache``). Nothing here knows a model, a network,
the robot, a result folder or a figure (an import contract in ``pyproject.toml``)."""
