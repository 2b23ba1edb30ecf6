"""Model files (TOML) shipped as examples: variants with the interface of a built-in model."""
