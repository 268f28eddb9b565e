"""Package data: the cast's catalogue, one folder per model (docs/cast.md); shipped in the wheel."""
