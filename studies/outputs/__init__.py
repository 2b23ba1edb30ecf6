"""Output folders: manifests with parameters, seed and versions; atomic writes and folder locks;
reading weights and folders back (``result``: :class:`~astrocpg.studies.outputs.result.Result`,
what ``ac.load`` returns); export to NWB and npz."""
