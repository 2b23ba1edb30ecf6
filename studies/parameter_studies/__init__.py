"""Parameter studies: study files (TOML) of conditions, sweep axes and seeds, their runs on the
runtime's engine, resumable; reports of their results (Fig. 3c and final figures: the
orchestration and the files here, the statistics in ``analysis``, the drawings in ``figures``);
the batching of seeds into runs, planned from each machine's measured cost of a trial
(``trial_cost``); and their Python API (``api``: ``ac.study``, ``ac.report``)."""
