"""Parameter studies: study files (TOML) of conditions, sweep axes and seeds, run on Dask and
resumable; reports of their results (Fig. 3c and final figures)."""
