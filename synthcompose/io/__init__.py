"""Reading and writing files: every codec (files), the JSON layout, and stage 1, the image sets read checked (dataset)."""
