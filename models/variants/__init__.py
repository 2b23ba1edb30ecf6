"""Model files (TOML, no code) shipped as examples, each a variant with the interface of a
built-in model, given with the ``models`` setting (``MODEL=FILE``; ``ac.run(models={...})``):
other astrocyte models (Li-Rinzel, G-ChI), the authors' inter-limb delays, an alive test by
height, and study files that compare them. Read one with
``importlib.resources.files("astrocpg.models.variants")``."""
