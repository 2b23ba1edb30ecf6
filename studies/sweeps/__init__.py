"""Parameter studies: study files (TOML) of conditions, sweep axes and seeds, run on Dask and
resumable; reports of their results (Fig. 3c and final figures); the batching of seeds into runs;
and their Python API (``api``: ``ac.study``, ``ac.report``)."""
