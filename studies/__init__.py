"""What is done with the model: the commands, parameter studies over them, their analysis,
figures and output folders, and the runtime they run on.

Sub-packages, each importing only those below it (checked by import-linter, see pyproject.toml):

  cli                the ``astrocpg`` command line: parses arguments and calls the functions below
  parameter_studies  parameter studies (TOML files) of many runs, and their reports
  commands           one unit, one closed-loop run, one training, evaluate, power, plot and
                     video (the Python API)
  figures            plots of results, rendered equations and parameter tables (pictures out)
  analysis           rhythm, gait and statistics of spikes, sessions and studies (numbers out)
  outputs            output folders: manifests, atomic writes, locks, checkpoints, the finished
                     cells of an interrupted evaluation, loading (Result), NWB/npz export
  runtime            the engine of many cells (here or on Dask), progress bars, memory checks,
                     caches
"""
