"""Running image sets: one through every stage (pipeline), many in processes or Ray actors (engines), the batch."""
