"""Output folders: manifests with parameters, seed and versions; atomic writes; reading weights
and folders back; export to NWB and npz."""
