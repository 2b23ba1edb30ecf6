"""What is done with the model: experiments, sweeps over them, their analysis, figures and
output folders.

Sub-packages, each importing only those below it (checked by import-linter, see pyproject.toml):

  cli          the ``astrocpg`` command line: parses arguments and calls the functions below
  sweeps       parameter studies (TOML files) on Dask, and their reports
  experiments  one unit, one closed-loop run, one training, the power estimate (the Python API)
  figures      plots of results, rendered equations and parameter tables
  analysis     rhythm, gait and statistics of spikes and sessions (numpy in, numbers out)
  outputs      output folders: manifests, atomic writes, locks, checkpoints, loading (Result),
               NWB/npz export
"""
